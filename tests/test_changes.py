"""Change detection on a synthetic pair with known changes."""

from __future__ import annotations

import json

import shapely
from click.testing import CliRunner

import tdb
from ingest.pipeline import ingest
from ingest.synth import apply_changes, make_scene, sample
from queries.changes import detect, level_of_detection
from tdb.cli import main


def test_dug_and_filled_ditches_are_found_and_typed(tmp_path):
    scene = make_scene(seed=7, size=150)
    later, changes = apply_changes(scene, seed=7)
    db = tdb.open(tmp_path / "p.tdb", create=True)
    ingest(sample(scene, density=3, seed=7), db, version="a")
    ingest(sample(later, density=3, seed=8), db, version="b")
    assert 0.1 <= level_of_detection(db, "a", "b") < 0.3
    found = detect(db, "a", "b")
    assert found
    regions = [(shapely.geometry.shape(f["geometry"]), f["properties"]) for f in found]
    for change in changes:
        if change.kind not in ("ditch_dug", "ditch_filled"):
            continue
        hits = [p for g, p in regions if g.intersects(change.area)]
        assert hits, f"{change.kind} not found"
        assert any(p["kind"] == change.kind.replace("_", " ") for p in hits)
        assert all((p["dz"] < 0) == (change.dz < 0) for p in hits if p["kind"].startswith("ditch"))
    # The CLI says the same, as GeoJSON, and draws a map.
    runner = CliRunner()
    r = runner.invoke(main, ["diff", "a", "b", "--db", str(tmp_path / "p.tdb"), "--png", str(tmp_path / "c.png")])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["type"] == "FeatureCollection" and len(doc["features"]) == len(found)
    assert (tmp_path / "c.png").exists()
