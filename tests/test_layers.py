"""The layer order of ema_rig, stated once and checked on every import of every module.

The order (bottom to top) is the table ``LAYERS`` below; ``ema_rig/__init__.py`` explains it in
words. Every ``import`` of every module is parsed with :mod:`ast` -- the ones inside functions and
under ``if TYPE_CHECKING:`` included -- and

* no module imports a module of a higher layer (``test_no_upward_import``);
* the module import graph has no cycle (``test_no_import_cycle``), so no layer hides a loop
  behind an import inside a function;
* an import inside a function is there only to keep a light module light: the target is an
  optional or heavy third-party package listed in ``LAZY_EXTERNAL`` with its reason, or an
  ema_rig module that imports a heavy package at import time while the importer does not
  (``tests/test_cold_start.py``: ``import ema_rig``, ``ema_rig.campaign`` and every command's
  start-up stay free of numpy) (``test_function_level_imports_have_a_reason``);
* no private name (``_x``) of one module is imported into another
  (``test_no_private_name_crosses_a_module``), and no private module of a subpackage is imported
  from outside it (``test_no_private_module_is_imported_from_another_package``), apart from the
  listed exceptions.

``python benchmarks/import_counts.py [-v]`` prints the counts (imports inside functions, under
``TYPE_CHECKING``, violations) and, with ``-v``, each violation.
"""

from __future__ import annotations

import ast
import functools
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "ema_rig"

# ------------------------------------------------------------------ the layer order, stated once
# (rank, module or package prefix); the longest matching prefix wins. Within a layer a module may
# import a module of the same or a lower rank; the cycle test keeps same-rank imports acyclic.
LAYERS: tuple[tuple[int, str], ...] = (
    # 0: foundations -- plain helpers, errors, DOFs, the FRF object and its processing record
    (0, "ema_rig._atomic"), (0, "ema_rig._blas"), (0, "ema_rig._linalg"), (0, "ema_rig._optional"), (0, "ema_rig._progress"),
    (0, "ema_rig._text"), (0, "ema_rig._threads"), (0, "ema_rig._version"), (0, "ema_rig.errors"), (0, "ema_rig.dof"),
    (0, "ema_rig.literals"), (0, "ema_rig.frf"), (0, "ema_rig.processing"),
    # 1: io -- reads and writes DOFs, units and data; knows no rig (nor the identification: mode
    #    shapes reach the dataset-55 writer as records of mode_shapes, on a structural ModalShapes)
    (1, "ema_rig.io"), (1, "ema_rig.mode_shapes"),
    # 2: identification -- poles, stabilization, LSFD, ML; spectral estimation (H1/H2/Hv)
    (2, "ema_rig.identification"), (2, "ema_rig.spectral"),
    # 3: the rig -- its file, sensor roles, model, candidates, matching, inversion, fit,
    #    uncertainty, stiffness, Hertz; the simulator of a rig measurement
    (3, "ema_rig.config"), (3, "ema_rig.rig"), (3, "ema_rig.simulate"),
    # 4: campaign core -- the campaign file, the result table; the bundled demo data set
    (4, "ema_rig.campaign.schema"), (4, "ema_rig.campaign.result"), (4, "ema_rig.demo_data"),
    # 5: outputs -- figures, the per-measurement drill-down, the report, the campaign's outputs
    (5, "ema_rig.plot"), (5, "ema_rig.campaign.drilldown"), (5, "ema_rig.report"),
    (5, "ema_rig.campaign.outputs"),
    # 6: the campaign run (process every measurement, then write the outputs) and its facade
    (6, "ema_rig.campaign.runner"), (6, "ema_rig.campaign"),
    # 7: commands and the command line; the package facade re-exports from every layer
    (7, "ema_rig.commands"), (7, "ema_rig.cli"), (7, "ema_rig.__main__"), (7, "ema_rig"),
)
LAYER_NAMES = ("foundations", "io", "identification", "rig", "campaign core", "outputs", "campaign run",
               "commands")

# Third-party or platform packages a function may import, with the reason it is not at module level.
LAZY_EXTERNAL: dict[str, str] = {
    "scipy": "heavy (~0.2-0.5 s); only the functions that solve with it pay for it",
    "matplotlib": "heavy; importing ema_rig must not touch matplotlib (STYLE 1.3) -- only a drawing function does",
    "mpl_toolkits": "matplotlib's 3-D toolkit, only for 3-D shape plots",
    "PIL": "matplotlib's image library, only to stamp PNG metadata",
    "pyuff": "heavy and only for the datasets ema_rig hands to it (55, 15, 2411, 82)",
    "sdypy": "optional peer for the crosscheck; it imports pyplot on import",
    "threadpoolctl": "optional: BLAS thread limits only when it is installed",
    "tqdm": "only when a progress bar is shown (CLI)",
    "numpy": "only in modules that must load without it: config and _atomic (imported by `import ema_rig`) and "
             "the commands (the CLI's start-up) (test_cold_start)",
    "importlib": "importlib.metadata costs ~40 ms; only when the version is asked for",
    "fcntl": "POSIX only (file locks)",
    "msvcrt": "Windows only (file locks)",
    "ctypes": "Linux only (prctl in forked workers)",
}
# ema_rig modules a function may import from a module that must not load them at import time:
# (importer prefix, target prefix) -> reason.
LAZY_INTERNAL: dict[tuple[str, str], str] = {
    ("ema_rig.campaign", "ema_rig.plot"): "a campaign run loads the drawing modules only when it draws "
                                          "(test_campaign_faults::test_runner_does_not_import_plotting)",
    ("ema_rig.campaign", "ema_rig.report"): "a campaign run loads the report writer only when it writes it "
                                            "(test_campaign_faults::test_runner_does_not_import_plotting)",
}
HEAVY = ("numpy", "scipy", "matplotlib", "pandas", "pyarrow", "dask", "distributed", "tqdm", "threadpoolctl",
         "sdypy", "pyuff", "PIL", "mpl_toolkits")

# Private names imported from another module that issue 21 leaves, each with its reason.
PRIVATE_ALLOWED: frozenset[tuple[str, str, str]] = frozenset({
    # identification/{identification,judge,lsfd,stabilization}.py are being rewritten in issue 18
    # (engineer i18c), who owns these seams; promote them there
    ("ema_rig.identification.judge", "ema_rig.identification.lsfd", "_design"),
    ("ema_rig.identification.judge", "ema_rig.identification.lsfd", "_output_chunks"),
    ("ema_rig.identification.judge", "ema_rig.identification.lsfd", "_projector"),
    ("ema_rig.identification.judge", "ema_rig.identification.stabilization", "_modes_from_rows"),
    ("ema_rig.identification.identification", "ema_rig.identification.lsfd", "_lsfd_checked"),
    ("ema_rig.identification.identification", "ema_rig.identification.lsfd", "_lsfd_noise_weighted"),
    ("ema_rig.identification.identification", "ema_rig.identification.judge", "_fit"),
})


@dataclass(frozen=True)
class Imp:
    """One imported name: ``importer`` imports ``target`` (a module) at ``line``."""

    importer: str
    target: str
    name: str  # the name imported from target ("" for ``import target``)
    line: int
    in_function: bool
    type_checking: bool


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def _is_type_checking(test: ast.expr) -> bool:
    return "TYPE_CHECKING" in ast.unparse(test)


@functools.cache
def collect_imports() -> tuple[Imp, ...]:
    """Every import of every module of ema_rig (inside functions and under TYPE_CHECKING included).

    Parsed once per session (every module of the package, ~1 s): the six checks below read the
    same sources, which do not change while the tests run.
    """
    mods = _modules()
    out: list[Imp] = []
    for mod, path in mods.items():
        is_pkg = path.name == "__init__.py"

        def handle(node: ast.AST, in_fn: bool, tc: bool, mod: str = mod, is_pkg: bool = is_pkg) -> None:
            if isinstance(node, ast.Import):
                for a in node.names:
                    out.append(Imp(mod, a.name, "", node.lineno, in_fn, tc))
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod.split(".") if is_pkg else mod.split(".")[:-1]
                    base = base[: len(base) - (node.level - 1)]
                    tgt = ".".join(base + ([node.module] if node.module else []))
                else:
                    tgt = node.module or ""
                for a in node.names:
                    sub = f"{tgt}.{a.name}"
                    out.append(Imp(mod, sub if sub in mods else tgt, a.name, node.lineno, in_fn, tc))

        def walk(node: ast.AST, in_fn: bool, tc: bool) -> None:
            for ch in ast.iter_child_nodes(node):
                if isinstance(ch, ast.If) and _is_type_checking(ch.test):
                    for b in ch.body:
                        handle(b, in_fn, True)
                        walk(b, in_fn, True)
                    for b in ch.orelse:
                        handle(b, in_fn, tc)
                        walk(b, in_fn, tc)
                    continue
                handle(ch, in_fn, tc)
                walk(ch, in_fn or isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)), tc)

        walk(ast.parse(path.read_text(encoding="utf-8")), False, False)
    return tuple(out)


def layer_of(module: str) -> int:
    # the package facade "ema_rig" is one module; every other entry also covers its submodules
    best = max((p for _, p in LAYERS if module == p or (p != "ema_rig" and module.startswith(p + "."))),
               key=len, default=None)
    if best is None:
        raise AssertionError(f"{module} is in no layer: add it to LAYERS in tests/test_layers.py")
    return next(r for r, p in LAYERS if p == best)


def _internal(imps: Sequence[Imp]) -> list[Imp]:
    return [i for i in imps if i.target == "ema_rig" or i.target.startswith("ema_rig.")]


def upward_imports(imps: Sequence[Imp]) -> list[str]:
    """Every import of a module from a higher layer, as 'importer:line -> target (layer -> layer)'."""
    bad = []
    for i in _internal(imps):
        a, b = layer_of(i.importer), layer_of(i.target)
        if b > a:
            bad.append(f"{i.importer}:{i.line} -> {i.target} ({LAYER_NAMES[a]} -> {LAYER_NAMES[b]})")
    return sorted(set(bad))


def import_cycles(imps: Sequence[Imp]) -> list[list[str]]:
    """The strongly connected components (more than one module) of the module import graph."""
    graph: dict[str, set[str]] = {m: set() for m in _modules()}
    for i in _internal(imps):
        if i.target != i.importer:
            graph[i.importer].add(i.target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    sccs: list[list[str]] = []
    counter = [0]
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))

    def strong(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                sccs.append(sorted(comp))

    for v in graph:
        if v not in index:
            strong(v)
    return sorted(sccs)


def _heavy_at_import(imps: Sequence[Imp]) -> dict[str, bool]:
    """Whether importing each module imports a heavy package (its module-level closure, parents included)."""
    mods = _modules()
    deps: dict[str, set[str]] = {m: set() for m in mods}
    for i in imps:
        if i.in_function or i.type_checking:
            continue
        deps[i.importer].add(i.target)
    for m in mods:  # importing a.b.c runs a/__init__ and a/b/__init__ first
        parts = m.split(".")
        deps[m].update(".".join(parts[:k]) for k in range(1, len(parts)))
    memo: dict[str, bool] = {}

    def heavy(m: str, seen: frozenset[str]) -> bool:
        if m in memo:
            return memo[m]
        if m.split(".")[0] in HEAVY:
            return True
        if m not in mods or m in seen:
            return False
        r = any(heavy(d, seen | {m}) for d in deps[m])
        if not seen:
            memo[m] = r
        return r

    return {m: heavy(m, frozenset()) for m in mods}


def _lazy_internal_reason(importer: str, target: str) -> str | None:
    for (a, b), why in LAZY_INTERNAL.items():
        if (importer == a or importer.startswith(a + ".")) and (target == b or target.startswith(b + ".")):
            return why
    return None


def unjustified_function_level_imports(imps: Sequence[Imp]) -> list[str]:
    heavy = _heavy_at_import(imps)
    bad = []
    for i in imps:
        if not i.in_function:
            continue
        top = i.target.split(".")[0]
        if top == "ema_rig":
            if heavy.get(i.target, False) and not heavy[i.importer]:
                continue  # keeps a light module light (cold start)
            if _lazy_internal_reason(i.importer, i.target):
                continue
            why = ("the target imports nothing heavy" if not heavy.get(i.target, False)
                   else f"{i.importer} is heavy already")
            bad.append(f"{i.importer}:{i.line} imports {i.target} inside a function ({why}): move it to the top")
        elif top not in LAZY_EXTERNAL:
            bad.append(f"{i.importer}:{i.line} imports {i.target} inside a function: move it to the top "
                       "(or list it in LAZY_EXTERNAL with its reason)")
    return sorted(set(bad))


def private_imports(imps: Sequence[Imp]) -> list[str]:
    """Private names (``_x``) imported from another module (ema_rig's or a third party's)."""
    bad = []
    for i in imps:
        if not i.name.startswith("_") or i.name.startswith("__") or i.target.endswith("." + i.name):
            continue  # a public name, a dunder, or a private module imported as a module
        if i.target != i.importer and (i.importer, i.target, i.name) not in PRIVATE_ALLOWED:
            bad.append(f"{i.importer}:{i.line} imports {i.target}.{i.name}")
    return sorted(set(bad))


# Private modules of a subpackage imported from outside it, each with its reason.
PRIVATE_MODULES_ALLOWED: dict[tuple[str, str], str] = {
    # `ema-rig frf` writes FRFs, coherence and processing history as one UFF file byte by byte;
    # a public writer of all three in ema_rig.io would replace these three imports
    ("ema_rig.commands.frf", "ema_rig.io._uff_1858"): "the frf command's dataset-1858 writer",
    ("ema_rig.commands.frf", "ema_rig.io._uff58_coherence"): "the frf command's coherence datasets",
    ("ema_rig.commands.frf", "ema_rig.io._uff_write"): "the frf command's date id line",
    # the campaign's figure phase draws through issue 22's renderer (plot/_render.py, owned by
    # that engineer); to become a public ema_rig.plot module once it settles
    ("ema_rig.campaign.drilldown", "ema_rig.plot._render"): "the figure renderer of issue 22",
    ("ema_rig.campaign.outputs", "ema_rig.plot._render"): "the figure renderer of issue 22",
    ("ema_rig.campaign.runner", "ema_rig.plot._render"): "the renderer's warm-up before the pool forks (issue 22)",
}


def private_module_imports(imps: Sequence[Imp]) -> list[str]:
    """Imports of a subpackage's private module (``ema_rig.io._uff_units``) from outside that subpackage.

    ``ema_rig``'s own private modules (``ema_rig._atomic``, ``ema_rig._text``) are the whole
    package's helpers and may be imported anywhere in it.
    """
    bad = []
    for i in _internal(imps):
        parts = i.target.split(".")
        k = next((k for k, part in enumerate(parts) if part.startswith("_")), None)
        if k is None or k < 2:
            continue
        pkg = ".".join(parts[:k])
        if i.importer == pkg or i.importer.startswith(pkg + "."):
            continue
        if (i.importer, i.target) not in PRIVATE_MODULES_ALLOWED:
            bad.append(f"{i.importer}:{i.line} imports {i.target} (private to {pkg})")
    return sorted(set(bad))


def counts(imps: Sequence[Imp]) -> dict[str, int]:
    stmts_fn = {(i.importer, i.line) for i in imps if i.in_function}
    stmts_tc = {(i.importer, i.line) for i in imps if i.type_checking}
    stmts_fn_int = {(i.importer, i.line) for i in _internal(imps) if i.in_function}
    return {
        "function-level import statements": len(stmts_fn),
        "  of them of ema_rig modules": len(stmts_fn_int),
        "TYPE_CHECKING import statements": len(stmts_tc),
        "upward imports": len(upward_imports(imps)),
        "import cycles": len(import_cycles(imps)),
        "unjustified function-level imports": len(unjustified_function_level_imports(imps)),
        "private names across modules": len(private_imports(imps)),
        "private modules across packages": len(private_module_imports(imps)),
    }


# ---------------------------------------------------------------------------------------- tests
def test_every_module_has_a_layer() -> None:
    for m in _modules():
        layer_of(m)


def test_no_upward_import() -> None:
    bad = upward_imports(collect_imports())
    assert not bad, f"{len(bad)} upward imports:\n" + "\n".join(bad)


def test_no_import_cycle() -> None:
    cyc = import_cycles(collect_imports())
    assert not cyc, f"{len(cyc)} import cycles:\n" + "\n".join(" <-> ".join(c) for c in cyc)


def test_function_level_imports_have_a_reason() -> None:
    bad = unjustified_function_level_imports(collect_imports())
    assert not bad, f"{len(bad)} function-level imports without a reason:\n" + "\n".join(bad)


def test_no_private_name_crosses_a_module() -> None:
    bad = private_imports(collect_imports())
    assert not bad, f"{len(bad)} private names imported across modules:\n" + "\n".join(bad)


def test_no_private_module_is_imported_from_another_package() -> None:
    bad = private_module_imports(collect_imports())
    assert not bad, f"{len(bad)} private modules imported from outside their package:\n" + "\n".join(bad)


def test_the_parser_sees_lazy_and_type_checking_imports() -> None:
    # the checker itself: a known function-level import and a known TYPE_CHECKING import are found
    imps = collect_imports()
    assert any(i.importer == "ema_rig._version" and i.target == "importlib.metadata" and i.in_function for i in imps)
    assert any(i.importer == "ema_rig" and i.type_checking for i in imps)
    assert layer_of("ema_rig.io.uff") < layer_of("ema_rig.identification.lsfd") < layer_of("ema_rig.rig.stiffness")

