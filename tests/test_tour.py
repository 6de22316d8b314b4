"""``examples/tour.py`` at a reduced size: every figure of the guided tour and the page that shows them.

The full tour (``python examples/tour.py``, about a minute on two cores) writes ``docs/tour/`` and
``docs/tour.md``; this runs the same code with ``--small`` into a temporary folder and checks that
every section's figure is written, is a small PNG, and is shown on the page with its equation.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TOUR = ROOT / "examples" / "tour.py"

pytest.importorskip("matplotlib")

#: every figure the tour writes (the real recording's only when ../shared/data/real is there)
FIGURES = ("01_sample.png", "02_pixel.png", "03_windows.png", "04_noise_check_sample.png", "05_blindspot.png",
           "06_denoiser.png", "07_steps.png", "08_warp.png", "09_ladder.png", "10_video.png")
#: the equations and figures of the paper the page must cite
CITED = ("Eq. 1", "Eq. 3", "Eq. 4", "Fig. 4a", "Eq. 9", "Eq. 10–11", "Eq. 12", "Fig. 3(b)", "Fig. 5", "Eq. 13",
         "Eq. 14", "Eq. 15", "stage ladder")


def _load_tour():
    spec = importlib.util.spec_from_file_location("spikeref_tour", TOUR)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def small_tour(tmp_path_factory):
    out = tmp_path_factory.mktemp("tour") / "tour"
    files = _load_tour().main(["--out", str(out), "--small"])
    return out, files


def test_every_figure_is_written_small(small_tour):
    out, files = small_tour
    names = {p.name for p in files}
    assert set(FIGURES) <= names
    if (ROOT.parent / "shared" / "data" / "real" / "spikingsim_real_spike.npz").is_file():
        assert "04_noise_check_real.png" in names
    for name in names - {"tour.md"}:
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n", name
        assert len(data) < 150_000, f"{name} is {len(data)} bytes"


def test_the_page_shows_every_figure_with_its_equation(small_tour):
    out, files = small_tour
    page = out.parent / "tour.md"
    assert files[-1] == page
    text = page.read_text()
    shown = re.findall(r"!\[[^\]]*\]\(tour/([^)]+)\)", text)
    assert sorted(shown) == sorted(p.name for p in files[:-1])
    for cite in CITED:
        assert cite in text, cite
    assert "nan dB" not in text and "{" not in text  # every number was filled in


def test_the_committed_tour_lists_the_same_figures():
    """docs/tour.md (the full run, committed) shows every figure the tour makes, and each file is there."""
    page = ROOT / "docs" / "tour.md"
    text = page.read_text()
    shown = re.findall(r"!\[[^\]]*\]\(tour/([^)]+)\)", text)
    assert set(FIGURES) <= set(shown)
    for name in shown:
        path = ROOT / "docs" / "tour" / name
        assert path.is_file(), name
        assert path.stat().st_size < 150_000, name
    assert "--small" not in text


def test_the_readme_links_the_tour_in_its_first_screen():
    lines = (ROOT / "README.md").read_text().splitlines()
    block_end = [i for i, line in enumerate(lines) if line.startswith("```")][1]  # the two commands' block
    assert any("(docs/tour.md)" in line for line in lines[block_end + 1:block_end + 4])
