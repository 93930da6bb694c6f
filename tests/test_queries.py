"""Query language, filters as data, and feature queries on a stored scene."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from queries.filters import builtin_filters, components, parse_filter
from queries.language import parse
from queries.run import run
from tdb.categories import all_categories
from tdb.errors import FilterError, QueryError


def test_parse_full_query():
    q = parse('SELECT ditch FROM "2020" WHERE bbox(1, 2, 3, 4) AND length > 20 AND depth >= 0.5 AT LEVEL 2')
    assert (q.what, q.version, q.bbox, q.level) == ("ditch", "2020", (1.0, 2.0, 3.0, 4.0), 2)
    assert [(c.attribute, c.op, c.value) for c in q.conditions] == [("length", ">", 20.0), ("depth", ">=", 0.5)]
    q = parse("select tiles from v1 where category in (10, 16,22)")
    assert q.categories == [10, 16, 22]
    q = parse("SELECT changes FROM a TO b AT LEVEL 8")
    assert (q.version, q.to_version, q.level) == ("a", "b", 8)
    q = parse("SELECT changes FROM a TO b WHERE kind IN ('ditch dug', 'ditch filled') AND dz < -0.5")
    assert [(c.attribute, c.op, c.value) for c in q.conditions] == [
        ("kind", "in", ("ditch dug", "ditch filled")),
        ("dz", "<", -0.5),
    ]
    q = parse("SELECT ditch FROM v WHERE kind != 'x' AT LEVEL 4 ORDER BY length DESC LIMIT 3")
    assert (q.order_by, q.descending, q.limit, q.level) == ("length", True, 3, 4)
    q = parse("SELECT tiles FROM v ORDER BY category ASC")
    assert (q.order_by, q.descending, q.limit) == ("category", False, None)


@pytest.mark.parametrize(
    "text,line,column",
    [
        ("SELECT ditch FROM", 1, 18),
        ("SELECT ditch\nFROM v1 WHERE length >> 2", 2, 23),
        ("SELECT ditch FROM v1 AT LEVEL 3", 1, 31),
        ("SELECT ditch FROM v1 WHERE bbox(3, 3, 1, 1)", 1, 28),
        ("SELECT ditch FROM v1 WHERE colour = 2", 1, 28),
        ("SELECT ditch FROM v1 ; DROP TABLE tdb", 1, 22),
        ("SELECT changes FROM a TO b WHERE kind > 'ditch dug'", 1, 39),
        ("SELECT changes FROM a TO b WHERE kind = 2", 1, 41),
        ("SELECT ditch FROM v1 LIMIT 2.5", 1, 28),
        ("SELECT ditch FROM v1 ORDER length", 1, 28),
        ("SELECT ditch FROM v1 LIMIT 2 ORDER BY length", 1, 30),
    ],
)
def test_parse_errors_locate_the_problem(text, line, column):
    with pytest.raises(QueryError) as info:
        parse(text)
    assert (info.value.line, info.value.column) == (line, column)
    assert "^" in str(info.value)


def test_a_version_name_that_needs_quotes_is_shown_quoted():
    with pytest.raises(QueryError, match='double quotes: FROM "survey-2020"'):
        parse("SELECT ditch FROM survey-2020 WHERE depth > 1")
    with pytest.raises(QueryError, match=r'TO "b\.2"'):
        parse("SELECT changes FROM a TO b.2")
    with pytest.raises(QueryError) as info:
        parse("SELECT ditch FROM a WHERE depth >= 0.5 ; x")
    assert "quotes" not in str(info.value)
    assert parse('SELECT ditch FROM "survey-2020"').version == "survey-2020"


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=80))
def test_any_text_parses_or_raises_query_error(text):
    try:
        parse(text)
    except QueryError:
        pass


@settings(max_examples=150, deadline=None)
@given(
    st.lists(
        st.sampled_from(
            [
                "SELECT",
                "ditch",
                "tiles",
                "FROM",
                "v",
                "TO",
                "WHERE",
                "bbox(0,0,9,9)",
                "AND",
                "length",
                ">",
                "3",
                "AT",
                "LEVEL",
                "2",
                "category",
                "IN",
                "(1,2)",
                "kind",
                "=",
                "'ditch dug'",
                "ORDER",
                "BY",
                "DESC",
                "LIMIT",
                "(",
                ")",
                ",",
            ]
        ),
        max_size=14,
    )
)
def test_keyword_soup_parses_or_raises_query_error(words):
    try:
        parse(" ".join(words))
    except QueryError:
        pass


def test_builtin_filters_validate():
    assert set(builtin_filters()) == {"ditch", "ridge", "wall", "embankment", "pit", "mound"}


@pytest.mark.parametrize(
    "doc",
    [
        {"name": "x"},
        {"name": "x", "features": ["gully"], "linear": True},
        {"name": "Bad Name", "features": ["ridge"], "linear": True},
        {"name": "x", "features": ["ridge"], "linear": True, "level": 3},
    ],
)
def test_invalid_filters(doc):
    with pytest.raises(FilterError):
        parse_filter(doc)


def test_linear_chain_needs_connected_break_lines():
    flt = parse_filter({"name": "chain", "features": ["valley"], "linear": True, "join": "lines"})
    cats = all_categories()
    north = next(c.code for c in cats if c.feature == 2 and c.orientation == (1, 7))  # valley S–N
    east = next(c.code for c in cats if c.feature == 2 and c.orientation == (3, 5))  # valley W–E
    xg = np.array([0, 0, 0, 2], np.int64)
    yg = np.array([0, 2, 4, 4], np.int64)
    # Three S–N valleys stacked: one chain; a W–E valley beside the top one does not join it.
    code = np.array([north, north, north, east], np.uint8)
    groups = components(xg, yg, code, flt, 2)
    assert [sorted(g.tolist()) for g in groups] == [[0, 1, 2], [3]]
    touching = parse_filter({"name": "blob", "features": ["valley"], "linear": True, "join": "touch"})
    assert [sorted(g.tolist()) for g in components(xg, yg, code, touching, 2)] == [[0, 1, 2, 3]]


def test_queries_on_a_database(tmp_path):
    from ingest.pipeline import ingest
    from ingest.synth import make_scene, sample

    scene = make_scene(seed=3, size=100)
    db = tdb.open(tmp_path / "q.tdb", create=True)
    ingest(sample(scene, density=3, seed=3), db, version="v1")
    valleys = [c.code for c in all_categories() if c.feature == 2]
    tiles = run(db, f"SELECT tiles FROM v1 WHERE category IN ({', '.join(map(str, valleys))})")
    assert tiles and all(f["properties"]["category"] in valleys for f in tiles)
    box = run(db, "SELECT tiles FROM v1 WHERE bbox(500010, 5500010, 500020, 5500020)")
    assert len(box) == 25
    for f in run(db, "SELECT ditch FROM v1 WHERE length > 5"):
        assert f["geometry"]["type"] in ("LineString", "MultiLineString") and f["properties"]["length"] > 5
    assert run(db, "SELECT changes FROM v1 TO v1") == []  # a survey compared with itself
    # Ordering and limits; text conditions.
    ditches = run(db, "SELECT ditch FROM v1")
    longest = run(db, "SELECT ditch FROM v1 ORDER BY length DESC LIMIT 1")
    lengths = sorted((f["properties"]["length"] for f in ditches), reverse=True)
    assert len(ditches) >= 2 and [f["properties"]["length"] for f in longest] == lengths[:1]
    shallow = run(db, "SELECT ditch FROM v1 ORDER BY depth")
    depths = [f["properties"]["depth"] for f in shallow]
    assert depths == sorted(depths) and len(shallow) == len(ditches)
    assert run(db, "SELECT ditch FROM v1 WHERE kind = 'ditch'") == ditches
    assert run(db, "SELECT ditch FROM v1 WHERE kind IN ('ridge', 'pit')") == []
    assert run(db, "SELECT ditch FROM v1 LIMIT 0") == []
    with pytest.raises(QueryError, match="no attribute 'area' to order by"):
        run(db, "SELECT ditch FROM v1 ORDER BY area")
    with pytest.raises(tdb.TdbError, match="no version"):
        run(db, "SELECT ditch FROM nope")
    json.dumps(run(db, "SELECT mound FROM v1"))
