"""The layering contract, read from the source: the core ``tdb/`` stands alone, ``ingest/`` and
``queries/`` stand on it and never on each other, and only ``tdb/cli/`` brings them together."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def imported_packages(path: Path) -> set[str]:
    """Top-level names of every module a file imports, anywhere in it (function bodies too)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
    return out


def _files(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def _top(names: set[str]) -> set[str]:
    return {n.split(".")[0] for n in names}


def _under(path: Path, part: str) -> bool:
    return part in path.relative_to(ROOT).parts[:-1]


FORBIDDEN = {
    "tdb": {"ingest", "queries"},
    "ingest": {"queries"},
    "queries": {"ingest"},
}


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_packages_import_only_what_the_layers_allow(package):
    broken = []
    for path in _files(package):
        if package == "tdb" and _under(path, "cli"):
            continue  # the command line is where the layers meet
        bad = _top(imported_packages(path)) & FORBIDDEN[package]
        if bad:
            broken.append(f"{path.relative_to(ROOT)} imports {', '.join(sorted(bad))}")
    assert not broken, "\n".join(broken)


def test_progress_bars_live_only_in_the_command_line():
    users = [
        str(p.relative_to(ROOT))
        for pkg in FORBIDDEN
        for p in _files(pkg)
        if "tqdm" in _top(imported_packages(p)) and not _under(p, "cli")
    ]
    assert not users


def test_no_library_module_switches_the_matplotlib_backend():
    users = [
        str(p.relative_to(ROOT))
        for pkg in FORBIDDEN
        for p in _files(pkg)
        if "matplotlib.pyplot" in imported_packages(p) or "matplotlib.use(" in p.read_text()
    ]
    assert not users


def test_the_walker_sees_imports_inside_functions(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def g():\n    from ingest.pipeline import ingest\n    import queries.run\n")
    assert _top(imported_packages(f)) == {"ingest", "queries"}


def test_drawing_a_map_leaves_the_matplotlib_backend_alone(tmp_path):
    import matplotlib

    from tdb.pictures import change_map

    before = matplotlib.get_backend()
    feature = {
        "type": "Feature",
        "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [4, 0], [4, 4], [0, 0]]]},
        "properties": {"kind": "mound removed", "dz": -1.0},
    }
    change_map(tmp_path / "c.png", [feature], title="t")
    assert matplotlib.get_backend() == before
    assert (tmp_path / "c.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
