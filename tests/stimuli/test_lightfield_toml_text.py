"""A ``lightfield.toml`` that is not UTF-8 text (Latin-1, UTF-16) is refused with one line naming
it, exit status 2, not a ``UnicodeDecodeError`` traceback."""

from __future__ import annotations

import pytest

from stimuli.errors import InputError
from stimuli.lfload import load_lightfield
from tests.conftest import run_cli

NOT_UTF8 = {
    "latin-1": "[geometry]\n# café\nbaseline_m = 0.01\n".encode("latin-1"),
    "utf-16": "[geometry]\nbaseline_m = 0.01\n".encode("utf-16"),
}


@pytest.mark.parametrize("encoding", NOT_UTF8)
def test_loader_refuses_with_one_line(tmp_path, encoding):
    lf = tmp_path / "lf"
    lf.mkdir()
    (lf / "lightfield.toml").write_bytes(NOT_UTF8[encoding])
    with pytest.raises(InputError) as exc:
        load_lightfield(lf)
    msg = str(exc.value)
    assert "lightfield.toml" in msg and "UTF-8" in msg and "\n" not in msg


def test_scan_refuses_with_exit_2(tmp_path, capsys):
    lf = tmp_path / "lf"
    lf.mkdir()
    (lf / "lightfield.toml").write_bytes(NOT_UTF8["latin-1"])
    assert run_cli(["lightfield", "scan", lf, "--out", tmp_path / "scan"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "lightfield.toml" in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "scan").exists()
