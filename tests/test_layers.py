"""The package's import graph: no import from a lower layer to a higher one, and no circle between modules.

Every import counts, those inside functions included (they still tie the layers together)."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "poir_mjx"
# Low to high: a module may import from its own layer's packages and from the layers below.
LAYERS = (
    {"quiet", "atomic", "cached", "compat", "optional", "devices", "versions", "checkpoint_codec", "run_state", "flags",
     "typed_config", "outputs", "folder_lock"},
    {"envs", "core"},
    {"rollout", "options"},
    {"data"},
    {"baselines"},
    {"eval"},
    {"online"},
    {"sweep"},
    {"bench", "video", "diagnose"},
    {"gpucheck"},
    {"cli"},
)
LAYER = {name: i for i, names in enumerate(LAYERS) for name in names}


def _modules() -> dict[str, Path]:
    mods = {}
    for f in PACKAGE.rglob("*.py"):
        parts = ("poir_mjx", *f.relative_to(PACKAGE).with_suffix("").parts)
        mods[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = f
    return mods


def _imports(mod: str, path: Path, mods: dict[str, Path]) -> set[str]:
    """The package's modules `mod` imports (``from poir_mjx.x import y`` counts y when it is a module, else x)."""
    out = set()
    package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name in mods}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base else []))
            for a in node.names:
                full = f"{base}.{a.name}"
                out.add(full if full in mods else base)
    return {m for m in out if m in mods and m != "poir_mjx" and m != mod}


def _layer(mod: str) -> int:
    top = mod.split(".")[1]
    if top not in LAYER:
        pytest.fail(f"{mod}: package or module {top!r} has no layer in tests/test_layers.py")
    return LAYER[top]


def test_no_import_goes_up_a_layer():
    mods = _modules()
    upward = [f"{m} -> {i}" for m, p in sorted(mods.items()) if m != "poir_mjx"
              for i in sorted(_imports(m, p, mods)) if _layer(i) > _layer(m)]  # fmt: skip
    assert not upward, "imports from a lower layer to a higher one:\n" + "\n".join(upward)


def test_no_import_circle():
    mods = _modules()
    graph = {m: _imports(m, p, mods) for m, p in mods.items()}
    state, circles = {}, []

    def visit(m, stack):
        state[m] = "open"
        for n in sorted(graph[m]):
            if state.get(n) == "open":
                circles.append(" -> ".join(stack[stack.index(n):] + [n]))
            elif n not in state:
                visit(n, stack + [n])
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert not circles, "import circles:\n" + "\n".join(circles)
