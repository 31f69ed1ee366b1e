"""Figure formats: PNG and PDF by default, SVG on request; the report links what was written."""

from __future__ import annotations

import pytest
from PIL import Image

from analysis.figure_formats import DEFAULT_FIGURE_FORMATS, parse_figure_formats
from analysis.report import FIGURE_NAMES, render_markdown
from tests.conftest import run_cli


def test_default_formats_are_png_and_pdf():
    assert DEFAULT_FIGURE_FORMATS == ("png", "pdf")
    assert parse_figure_formats(" PDF,svg,png,svg ") == ("png", "pdf", "svg")


@pytest.mark.parametrize("text", ["", "png,jpg", "eps", ","])
def test_bad_figure_formats_are_refused(text):
    with pytest.raises(ValueError, match="--figure-formats must be a comma-separated list"):
        parse_figure_formats(text)


def test_bad_figure_formats_option_exits_2_before_fitting(tmp_path, small_csv, capsys):
    out = tmp_path / "rep"
    assert run_cli(["analyze", small_csv, "--out", out, "--figure-formats", "png,gif"]) == 2
    err = capsys.readouterr().err
    assert "--figure-formats must be a comma-separated" in err and "got 'png,gif'" in err
    assert not out.exists()


@pytest.mark.parametrize("formats", [("png", "pdf"), ("png", "pdf", "svg"), ("svg",)])
def test_report_links_exactly_the_files_written(small_result, formats):
    text = render_markdown(small_result, figure_formats=formats)
    for name in FIGURE_NAMES:
        for ext in ("png", "pdf", "svg"):
            assert (f"({name}.{ext})" in text) is (ext in formats), (name, ext)


def test_saved_files_follow_the_formats(tmp_path):
    from matplotlib.figure import Figure

    from analysis.figures import PNG_DPI, save_figures

    def fig(label="x"):
        f = Figure(figsize=(3, 2), layout="constrained")
        ax = f.add_subplot()
        ax.plot([1, 2], [1, 3])
        ax.set_xlabel(label)
        return f

    written = save_figures({"a": fig()}, tmp_path)
    assert [p.name for p in written] == ["a.png", "a.pdf"]
    written = save_figures({"b": fig(), "c": fig("a long x label " * 6)}, tmp_path, ("svg", "png"))
    assert [p.name for p in written] == ["b.png", "b.svg", "c.png", "c.svg"]
    assert not (tmp_path / "b.pdf").exists()
    with Image.open(tmp_path / "a.png") as im:
        assert round(im.info["dpi"][0]) == PNG_DPI and im.mode == "RGB"
        assert 2.5 * PNG_DPI < im.size[0] <= 3 * PNG_DPI  # the figure, cut to its contents
    with Image.open(tmp_path / "c.png") as im:  # a label past the edge: the file grows to it
        assert round(im.info["dpi"][0]) == PNG_DPI and im.size[0] > 3 * PNG_DPI


def test_png_writer_round_trips_every_byte(tmp_path):
    import numpy as np

    from analysis.pngfile import write_png

    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
    img[10:20] = 255  # flat rows and wrap-around differences both
    write_png(tmp_path / "a.png", img[:, 1:-1], dpi=300, text={"Software": "x"})
    with Image.open(tmp_path / "a.png") as im:
        assert np.array_equal(np.asarray(im), img[:, 1:-1])
        assert round(im.info["dpi"][0]) == 300 and im.info["Software"] == "x"
    with pytest.raises(ValueError, match="uint8"):
        write_png(tmp_path / "b.png", img.astype(float), dpi=300)


@pytest.mark.parametrize("formats", [("svg",), ("png", "svg")])
def test_active_report_follows_the_formats(tmp_path, formats):
    from analysis.active import write_active_report
    from tests.analysis.test_active_survival import _active_log

    db = tmp_path / "a.sqlite"
    _active_log(db)
    rep = tmp_path / "rep"
    write_active_report([db], rep, figure_formats=formats)
    written = {p.suffix[1:] for p in rep.glob("active_time_to_recognition.*")}
    assert written == set(formats)
    # the report shows the PNG only when one was written
    assert ("active_time_to_recognition.png" in (rep / "report.md").read_text()) is (
        "png" in formats
    )
