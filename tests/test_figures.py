"""``docs/figures/`` is not stale: the committed figures match what ``python docs/make_figures.py`` draws now.

``make_figures`` writes ``docs/figures/manifest.json`` beside the PNGs: a hash of every
input (ships, settings, the weather datasets' values), each PNG's SHA-256 and the numbers
each figure shows.  Re-drawing the figures takes minutes (a route search across the
Pacific and two NLP studies), so this test recomputes only the cheap parts and compares:

* the inputs, rebuilt from the current code (a changed scenario, ship or setting fails);
* the PNG files against their hashes in the manifest (a figure copied in from elsewhere,
  e.g. the benchmarks' front, or left from an earlier run, fails; pixels are not compared
  with a fresh drawing, which would change with the matplotlib version);
* the great-circle baseline of the demo (Boeing's speed reduction along fixed waypoints,
  deterministic and cheap) re-sailed with the current physics against the numbers the
  figures show;
* the README's prose against the numbers of the last run.

A failure says: run ``python docs/make_figures.py`` and commit ``docs/figures/``.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
FIX = "run `python docs/make_figures.py` and commit docs/figures/"


@pytest.fixture(scope="module")
def make_figures(north_pacific_storms):
    """``docs/make_figures.py`` as a module; its demo weather (``scenarios.north_pacific_storms()`` at its
    defaults) is the suite's copy (tests/conftest.py, read only), not a second build in this process."""
    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "docs" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.demo_weather = lambda: north_pacific_storms
    return module


@pytest.fixture(scope="module")
def manifest():
    return json.loads((FIGURES / "manifest.json").read_text(encoding="utf-8"))


def test_every_png_is_the_one_the_manifest_records(manifest):
    on_disk = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in FIGURES.glob("*.png")}
    recorded = {name: fig["sha256"] for name, fig in manifest["figures"].items()}
    assert on_disk == recorded, f"the PNGs are not those of the last make_figures run; {FIX}"


def test_inputs_are_those_the_figures_were_drawn_from(make_figures, manifest):
    inputs = make_figures.figure_inputs(manifest["inputs"]["demo"]["cell_nm"])
    changed = sorted(
        f"{part}.{key}"
        for part in inputs
        for key in set(inputs[part]) | set(manifest["inputs"][part])
        if inputs[part].get(key) != manifest["inputs"][part].get(key)
    )
    assert changed == [], f"figure inputs changed since the figures were drawn: {changed}; {FIX}"
    assert make_figures.inputs_sha256(inputs) == manifest["inputs_sha256"], FIX


def test_great_circle_baseline_is_what_the_figures_show(make_figures, manifest):
    shown = manifest["figures"]["profile_great_circle.png"]["shows"]
    endpoints = manifest["figures"]["route_map.png"]["shows"]["endpoints"]
    now = make_figures.great_circle_numbers(endpoints)
    assert now == pytest.approx(shown, rel=1e-3), f"the physics changed the demo's baseline; {FIX}"
    # Boeing EP 2145155: the great circle through the storms takes more than 12 days
    assert shown["duration_h"] > 12 * 24


def test_readme_shows_the_figures_and_quotes_the_last_run(manifest):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for name in manifest["figures"]:
        assert f"(docs/figures/{name})" in readme
    missing = [q for q in manifest["readme_quotes"] if q not in readme]
    assert missing == [], f"README.md should say {missing} (docs/figures/manifest.json, readme_quotes)"


def test_front_figure_numbers_are_a_front(manifest):
    """The recorded front falls monotonically from the minimum-time passage to the slow-steaming limit."""
    front = manifest["figures"]["front.png"]["shows"]
    eta, fuel = np.array(front["eta_h"]), np.array(front["fuel_t"], dtype=float)
    assert np.all(np.diff(eta) > 0)
    assert eta[0] == pytest.approx(front["earliest_arrival_h"], abs=0.01)
    assert eta[-1] == pytest.approx(front["slow_steaming_limit_h"], abs=0.01)
    assert np.all(np.diff(fuel) <= 1e-6 * fuel[:-1])
    assert eta[0] <= front["knee_eta_h"] <= eta[-1]
