"""A battery of bad inputs and hostile arguments (issue 29): every one is refused in one line.

Each case runs the command line on a database holding two versions and on small files beside
it. It must exit non-zero with one ``tdb: error:`` line and no traceback, and leave the database
byte for byte as it was (the output files that would replace it included).
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from tdb.cli import main
from tests.conftest import digest, two_surveys


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A folder with ``park.tdb`` (versions a, b), a survey ``s.laz`` and hostile files."""
    root = two_surveys(tmp_path_factory.mktemp("battery"), seed=4, density=1)
    (root / "empty.laz").write_bytes(b"")
    (root / "noise.laz").write_bytes(np.random.default_rng(0).bytes(4000))
    (root / "cut.laz").write_bytes((root / "s.laz").read_bytes()[:3000])
    (root / "empty.xyz").write_text("")
    (root / "nan.xyz").write_text("1 2 nan\n3 4 5\n5 6 7\n")
    (root / "two.xyz").write_text("1 2\n3 4\n")
    (root / "line.xyz").write_text("".join(f"{i} {2 * i} 1\n" for i in range(20)))
    (root / "one.xyz").write_text("1 2 3\n")
    (root / "far.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n1e300 1 0\n")
    (root / "words.xyz").write_text("a b c\nd e f\n")
    (root / "folder").mkdir()
    (root / "not.sqlite").write_bytes(b"SQLite format 3\x00" + bytes(200))
    (root / "readme.txt").write_text("no points here\n")
    damaged = bytearray((root / "park.tdb").read_bytes())
    start, end = len(damaged) // 4, 3 * len(damaged) // 4  # the tiles' and points' pages
    damaged[start:end] = np.random.default_rng(1).bytes(end - start)
    (root / "damaged.tdb").write_bytes(bytes(damaged))
    return root


DB = "{root}/park.tdb"
S = "{root}/s.laz"
BAD_BBOXES = ["nan,0,1,1", "-inf,-inf,inf,inf", "0,0,1e15,1e15", "1,1,0,0", "a,b,c,d", "1,2,3", "1e300,0,1e300,1"]
BAD_QUERIES = [
    "",
    "SELECT",
    "SELECT ditch",
    "SELECT ditch FROM",
    "SELECT ditch FROM nope",
    "SELECT volcano FROM a",
    "SELECT ditch FROM a WHERE depth >",
    "SELECT ditch FROM a WHERE colour = 3",
    "DROP TABLE Tdb",
    "'; DROP TABLE Tdb; --",
    "SELECT changes FROM a TO nope",
    "SELECT ditch FROM a WHERE depth > nan",
]
NOT_LAS = ("missing.laz", "folder", "empty.laz", "noise.laz", "cut.laz")
GPKG = ["query", "SELECT ditch FROM a", "--db", DB, "--format", "gpkg", "--out"]
BAD_NAMES = ["", "   ", "a\nb", "x" * 201, "tab\there"]

CASES: list[list[str]] = [
    # reading what is not a survey
    *[["info", f"{{root}}/{f}"] for f in ("missing.laz", "folder", "empty.laz", "noise.laz", "cut.laz")],
    *[
        ["info", f"{{root}}/{f}"]
        for f in ("empty.xyz", "nan.xyz", "two.xyz", "one.xyz", "words.xyz", "readme.txt")
    ],
    ["info", "{root}/not.sqlite"],
    *[["ground", f"{{root}}/{f}", "--assume-metres"] for f in ("line.xyz", "far.xyz", "one.xyz", "nan.xyz")],
    # ingest: bad inputs and values
    *[
        ["ingest", f"{{root}}/{f}", "--db", DB, "--version", "c", "--assume-metres"]
        for f in (*NOT_LAS, "empty.xyz", "nan.xyz", "two.xyz", "one.xyz")
    ],
    *[["ingest", S, "--db", DB, "--version", n] for n in BAD_NAMES],
    ["ingest", S, "--db", DB, "--version", "a"],  # exists
    *[
        ["ingest", S, "--db", DB, "--version", "c", "--resolution", r]
        for r in ("nan", "inf", "0", "-1", "3", "0.3")
    ],
    *[["ingest", S, "--db", DB, "--version", "c", "--flat-threshold", t] for t in ("-1", "nan", "inf")],
    *[["ingest", S, "--db", DB, "--version", "c", "--exclude-classes", e] for e in ("300", "-1", "a", "7,,")],
    *[["ingest", S, "--db", DB, "--version", "c", "--bbox", b] for b in BAD_BBOXES],
    ["ingest", S, "--db", DB, "--version", "c", "--bbox", "0,0,10,10"],  # away from the survey
    *[["ingest", S, "--db", DB, "--version", "c", "--block", b] for b in ("0", "-16", "17", "nan")],
    *[["ingest", S, "--db", DB, "--version", "c", "--date", d] for d in ("yesterday", "2024-13-01")],
    ["ingest", S, "--db", "{root}/not.sqlite", "--version", "c"],
    ["ingest", S, "--db", "{root}/folder", "--version", "c"],
    # queries
    *[["query", q, "--db", DB] for q in BAD_QUERIES],
    ["query", "SELECT ditch FROM a", "--db", DB, "--out", DB],
    ["query", "SELECT ditch FROM a", "--db", DB, "--format", "gpkg", "--out", DB],
    ["query", "SELECT ditch FROM a", "--db", DB, "--out", "{root}/folder"],
    ["query", "SELECT ditch FROM a", "--db", DB, "--png", "{root}/x.tdb"],
    ["query", "SELECT ditch FROM a", "--db", DB, "--png", DB],
    ["query", "SELECT ditch FROM a", "--db", DB, "--format", "xml"],
    ["query", "SELECT ditch FROM a", "--db", "{root}/missing.tdb"],
    ["query", "SELECT ditch FROM a", "--db", "{root}/not.sqlite"],
    ["query", "SELECT ditch FROM a", "--db", "{root}/s.laz"],
    # areas of interest
    *[["aoi", "--db", DB, "--version", "a", "--bbox", b] for b in BAD_BBOXES],
    ["aoi", "--db", DB, "--bbox", "0,0,10,10"],  # two versions: which?
    ["aoi", "--db", DB, "--version", "nope", "--bbox", "0,0,10,10"],
    ["aoi", "--db", DB, "--version", "a", "--bbox", "0,0,10,10", "--level", "3"],
    # change
    ["diff", "a", "nope", "--db", DB],
    ["diff", "nope", "b", "--db", DB],
    ["diff", "a", "b", "--db", DB, "--coregister", "sideways"],
    ["diff", "a", "b", "--db", DB, "--out", DB],
    ["diff", "a", "b", "--db", DB, "--png", DB],
    ["diff", "a", "b", "--db", DB, "--dod", DB],
    ["diff", "a", "b", "--db", DB, "--png", "{root}/x.xyz"],
    *[["diff", "a", "b", "--db", DB, "--bbox", b] for b in BAD_BBOXES],
    # maintenance
    ["rm", "nope", "--db", DB],
    ["rename", "nope", "c", "--db", DB],
    ["rename", "a", "b", "--db", DB],
    *[["rename", "a", n, "--db", DB] for n in BAD_NAMES],
    ["check", "{root}/not.sqlite"],
    ["check", "{root}/missing.tdb"],
    ["check", "{root}/folder"],
    ["rm", "a", "--db", "{root}/missing.tdb"],
    # scenes and atlases
    ["synth", "--out", "{root}/z.laz", "--seed", "x"],
    [
        "query",
        "SELECT ditch FROM a",
        "--db",
        DB,
        "--format",
        "gpkg",
        "--out",
        "{root}/q.gpkg",
        "--layer",
        "gpkg_contents",
    ],
    [*GPKG, "{root}/q.xyz"],
    *[["synth", "--out", "{root}/z.laz", "--size", s] for s in ("0", "-5", "nan", "1e9")],
    *[["synth", "--out", "{root}/z.laz", "--density", d] for d in ("0", "-1", "nan", "1000")],
    ["synth", "--out", "{root}/folder"],
    ["synth", "--out", DB],
    ["synth", "--out", "{root}/z.laz", "--changed", "{root}/z.laz"],
    ["synth", "--out", "{root}/z.laz", "--changes", "{root}/c.geojson"],
    *[["categories", "--subgrid", g] for g in ("0", "4", "-3", "100000")],
    ["categories", "--atlas", "{root}/x.xyz"],
    ["categories", "--atlas", DB],
    ["ground", S, "--out", "{root}/folder"],
    ["ground", S, "--out", DB],
    ["ground", S, "--dtm", "{root}/x.xyz"],
    ["ground", S, "--resolution", "nan"],
    # what stands on the ground: unreadable inputs, outputs that cannot be written
    *[["classify", f"{{root}}/{f}", "--out", "{root}/c.laz"] for f in NOT_LAS],
    *[["trees", f"{{root}}/{f}", "--out", "{root}/t.gpkg"] for f in NOT_LAS],
    ["classify", S, "--out", DB],
    ["classify", S, "--out", "{root}/folder"],
    ["classify", S, "--out", "{root}/c.laz", "--buildings", "{root}/b.xyz"],
    ["trees", S, "--out", DB],
    ["trees", S, "--out", "{root}/t.png"],
    ["query", "SELECT object_changes FROM a", "--db", DB],
    ["query", "SELECT trees FROM a WHERE colour > 3", "--db", DB],
    # a database with random bytes in its middle
    *[
        [*args, "--db", "{root}/damaged.tdb"]
        for args in (
            ["query", "SELECT ditch FROM a"],
            ["query", "SELECT ridge FROM b"],
            ["aoi", "--version", "a", "--bbox", "500000,5500000,500100,5500100", "--out", "{root}/dmg"],
            ["diff", "a", "b"],
        )
    ],
    ["check", "{root}/damaged.tdb"],
]


def test_the_battery_holds_at_least_a_hundred_cases():
    assert len(CASES) >= 100
    assert len({tuple(c) for c in CASES}) == len(CASES)


@pytest.mark.parametrize("args", CASES, ids=[" ".join(c)[:60] for c in CASES])
def test_a_bad_input_is_refused_in_one_line_and_loses_nothing(site, args):
    before = {p.name: digest(p) for p in site.iterdir() if p.is_file()}
    argv = [a.replace("{root}", str(site)) for a in args]
    result = CliRunner().invoke(main, argv)
    text = result.output  # standard output and error, interleaved
    assert result.exit_code != 0, text
    assert "Traceback" not in text, text
    errors = [line for line in text.splitlines() if "error" in line.lower()]
    assert len(errors) == 1 and errors[0].startswith("tdb: error:") and len(errors[0]) < 500, text
    after = {p.name: digest(p) for p in site.iterdir() if p.is_file() and p.name in before}
    assert after == before  # nothing that was there changed, the database least of all
    for p in site.iterdir():  # nothing half-written left behind
        if p.name not in before:
            if p.is_dir():
                shutil.rmtree(p) if p.name != "folder" else None
            else:
                p.unlink()
