"""Sessions of a stimulus set with k conditions, their blocks counterbalanced by a Latin square."""

from __future__ import annotations

import json
from collections import Counter

import numpy as np
import pytest

from experiment.log import TrialLog
from experiment.protocol import ProtocolError
from experiment.session.schedule import latin_square_order
from tests.conftest import protocol_toml, run_cli
from tests.stimuli._build_fixtures import make_pair, write_png

CONDS = ("cluttered", "decluttered", "mask")


def test_latin_square_balances_positions():
    """Over a full cycle of subjects every condition is at every position equally often (odd k
    takes the mirrored rows too), and for even k every condition follows every other once."""
    for k in (3, 4):
        conds = tuple(f"c{i}" for i in range(k))
        n_rows = 2 * k if k % 2 else k
        orders = [latin_square_order(conds, s) for s in range(n_rows)]
        for pos in range(k):
            assert Counter(o[pos] for o in orders) == dict.fromkeys(conds, n_rows // k)
        if k % 2 == 0:
            pairs = Counter((o[i], o[i + 1]) for o in orders for i in range(k - 1))
            assert set(pairs.values()) == {1} and len(pairs) == k * (k - 1)
        assert latin_square_order(conds, n_rows) == orders[0]


@pytest.fixture(scope="module")
def three_condition_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("kcond")
    for i in range(2):
        wide, narrow, mask = make_pair(i, (120, 180))
        write_png(wide, root / "pairs" / f"obj{i:02d}" / "wide.png")
        write_png(narrow, root / "pairs" / f"obj{i:02d}" / "narrow.png")
        write_png(mask.astype(np.float32), root / "pairs" / f"obj{i:02d}" / "mask.png")
    argv = ["stimuli", "build", root / "pairs", "--out", root / "stim", "--working-size"]
    assert run_cli([*argv, "120x80", "--conditions", ",".join(CONDS)]) == 0
    return root


def test_sessions_counterbalance_condition_blocks(three_condition_set, tmp_path):
    """Three subjects' sessions: at each level one block per condition, in the subject's row of
    the Latin square, recorded in the session's counterbalance event."""
    root = three_condition_set
    proto = tmp_path / "k.toml"
    proto.write_text(
        protocol_toml(
            (1, 2),
            name="k3",
            conditions=CONDS,
            training=None,
            main_settings='condition_order = "latin_square"',
        )
    )
    db = tmp_path / "k.sqlite"
    for s in ("S01", "S02", "S03"):
        argv = ["session", "run", "--protocol", proto, "--stimuli", root / "stim", "--subject", s]
        assert run_cli([*argv, "--data", db, "--headless", "--seed", "3"]) == 0
    with TrialLog(db) as log:
        rows = log.tidy_trials()
        events = [e for e in log.events() if e["kind"] == "counterbalance"]
        sessions = {r["session_id"]: r["subject"] for r in log.sessions()}
    for i, s in enumerate(("S01", "S02", "S03")):
        want = latin_square_order(CONDS, i)
        for level in (1, 2):
            mine = sorted(
                (r["trial_index"], r["condition"])
                for r in rows
                if r["subject"] == s and r["level"] == level
            )
            seen = list(dict.fromkeys(c for _, c in mine))
            assert tuple(seen) == want, (s, level, seen)
    recorded = {sessions[e["session_id"]]: json.loads(e["note"]) for e in events}
    assert recorded["S02"]["subject_index"] == 1
    assert recorded["S02"]["condition_orders"]["0"] == list(latin_square_order(CONDS, 1))


def test_unknown_condition_is_refused(tmp_path):
    from experiment.protocol import load_protocol

    p = tmp_path / "bad.toml"
    p.write_text(protocol_toml((1,), conditions=("cluttered", "blurry"), training=None))
    with pytest.raises(ProtocolError, match="must be one of .*mask"):
        load_protocol(p)
