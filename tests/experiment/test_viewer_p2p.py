"""The optional pulse2percept adapter: tested when the ``p2p`` extra is installed."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from experiment.errors import ConfocalError
from experiment.viewer.p2p import p2p_percept
from stimuli.implants import load_implant
from tests.experiment.conftest import confocal_process


def test_missing_extra_names_the_install_command(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "pulse2percept", None)
    monkeypatch.setitem(sys.modules, "pulse2percept.implants", None)
    with pytest.raises(ConfocalError, match=r"pip install 'active-confocal\[p2p\]'"):
        p2p_percept(np.ones((6, 10)), load_implant("argus2"))


def test_bad_model_or_layout_refused() -> None:
    with pytest.raises(ConfocalError, match="p2p model must be one of"):
        p2p_percept(np.ones((6, 10)), load_implant("argus2"), model="nanduri")
    with pytest.raises(ConfocalError, match="no retinal pitch_um"):
        p2p_percept(np.ones((20, 20)), load_implant("brainport"))
    with pytest.raises(ConfocalError, match="must have the implant's shape"):
        p2p_percept(np.ones((5, 10)), load_implant("argus2"))


@pytest.mark.parametrize("model", ["scoreboard", "axonmap"])
def test_single_electrode_lands_where_it_is_on_the_grid(model, tmp_path, monkeypatch) -> None:
    pytest.importorskip("pulse2percept", reason="the p2p extra is not installed")
    monkeypatch.chdir(tmp_path)
    lay = load_implant("argus2")
    cells = np.zeros(lay.shape)
    assert not p2p_percept(cells, lay, model=model).any()  # zero in, zero out
    for r, c in [(0, 0), (5, 9), (2, 6)]:
        cells = np.zeros(lay.shape)
        cells[r, c] = 1
        p = p2p_percept(cells, lay, model=model)
        assert p.max() == pytest.approx(1.0)
        y, x = np.unravel_index(int(np.argmax(p)), p.shape)
        # electrode (r, c) sits at ((r + 0.5) / rows, (c + 0.5) / cols) of the field of view,
        # which the percept covers with one spacing of margin on each side
        fy = (1 + (r + 0.5)) / (lay.rows + 2)
        fx = (1 + (c + 0.5)) / (lay.cols + 2)
        tol = 0.5 / (lay.rows + 2) if model == "scoreboard" else 2.0 / (lay.rows + 2)
        assert abs(y / p.shape[0] - fy) < tol and abs(x / p.shape[1] - fx) < 2 * tol
    assert list(tmp_path.iterdir()) == []  # no axon cache left in the current folder


def test_view_command_writes_the_p2p_still(tmp_path) -> None:
    pytest.importorskip("pulse2percept", reason="the p2p extra is not installed")
    from PIL import Image

    lf = tmp_path / "scene.npz"
    r = confocal_process("lightfield", "synth", "--kind", "camera", "--size", "128x96", "--out", lf)
    assert r.returncode == 0, r.stderr
    shot = tmp_path / "v.png"
    r = confocal_process(
        "view", lf, "--cpu", "--implant", "argus2", "--p2p", "scoreboard",
        "--screenshot", shot, "--planes", "30",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    still = np.asarray(Image.open(tmp_path / "v_p2p.png"))
    assert still.ndim == 2 and still.max() == 255
    r = confocal_process("view", lf, "--p2p", "scoreboard")
    assert r.returncode == 2 and "--p2p needs --screenshot" in r.stderr
