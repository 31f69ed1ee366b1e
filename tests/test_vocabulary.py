"""One word per concept in the public API: ``level``, ``grey_levels``, ``pixels``.

``level`` is an index on the resolution ladder (1..8), ``grey_levels`` a number of grey levels,
``pixels`` the fitted stimulus axis (pixels per object or window). A parameter named ``levels``
may only hold ladder indices: no public function or class of ``analysis`` (which fits pixels and
never takes ladder indices) has one, and none of ``stimuli`` has one that is a single int (a
grey-level count).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

#: Public names allowed a ``levels`` parameter anyway, with the reason.
ALLOWED = {
    # The dataclass mirrors the implant TOML files' ``levels`` key (a user-written format,
    # also written into stimulus sets by ``to_dict``).
    "stimuli.implants.ImplantLayout",
}


ROOT = Path(__file__).resolve().parents[1]


def _exported(tree: ast.Module) -> set[str]:
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
        ):
            return {e.value for e in node.value.elts if isinstance(e, ast.Constant)}
    return set()


def _levels_params(package: str):
    """Yield ``(where, annotation, default)`` of each ``levels`` parameter of the public API.

    Read from the source (no imports, so the check costs well under a second): functions and
    classes named in a module's ``__all__``, their public methods and ``__init__``, and the
    fields of dataclasses.
    """
    for path in sorted((ROOT / package).rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        names = _exported(tree)
        mod = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        for node in tree.body:
            if getattr(node, "name", None) not in names:
                continue
            funcs = [(node.name, node)] if isinstance(node, ast.FunctionDef) else []
            if isinstance(node, ast.ClassDef):
                for item in node.body:
                    if isinstance(item, ast.FunctionDef) and (
                        item.name == "__init__" or not item.name.startswith("_")
                    ):
                        funcs.append((f"{node.name}.{item.name}", item))
                    elif (
                        isinstance(item, ast.AnnAssign)
                        and isinstance(item.target, ast.Name)
                        and item.target.id == "levels"
                    ):
                        default = item.value and ast.unparse(item.value)
                        yield f"{mod}.{node.name}", ast.unparse(item.annotation), default
            for where, fn in funcs:
                a = fn.args
                positional = [*a.posonlyargs, *a.args]
                padded = [None] * (len(positional) - len(a.defaults)) + list(a.defaults)
                pairs = [*zip(positional, padded, strict=True)]
                pairs += [*zip(a.kwonlyargs, a.kw_defaults, strict=True)]
                defaults = {x.arg: d for x, d in pairs if d is not None}
                for arg in [*positional, *a.kwonlyargs]:
                    if arg.arg == "levels":
                        ann = ast.unparse(arg.annotation) if arg.annotation else ""
                        d = defaults.get("levels")
                        yield f"{mod}.{where}", ann, d and ast.unparse(d)


def _is_single_int(annotation: str, default: str | None) -> bool:
    if annotation.replace(" ", "") in ("int", "int|None"):
        return True
    return default is not None and default.lstrip("-").isdigit()


@pytest.mark.parametrize("package", ["analysis", "stimuli"])
def test_no_levels_parameter_means_grey_count_or_pixels(package):
    """``levels`` names ladder indices only: never the pixels fitted or a grey-level count."""
    bad = [
        f"{where} (levels: {ann or '?'})"
        for where, ann, default in _levels_params(package)
        if where not in ALLOWED and (package == "analysis" or _is_single_int(ann, default))
    ]
    assert not bad, (
        "a parameter named `levels` that is not a set of ladder indices (use `pixels` for the "
        f"fitted stimulus values, `grey_levels` for a number of grey levels): {bad}"
    )


def test_weibull_fit_names_its_axis_pixels_and_results_json_keeps_its_key():
    """``WeibullFit`` has ``pixels`` and no ``levels``; results.json keeps its ``levels`` key."""
    import numpy as np

    from analysis.weibull import MLEstimate, WeibullFit, default_prior

    px = (96.0, 950.0, 17876.0)
    fit = WeibullFit(
        label="a",
        sigmoid="weibull",
        guess=0.0,
        pixels=px,
        k=(1.0, 5.0, 9.0),
        n=(10.0, 10.0, 10.0),
        mle=MLEstimate(1000.0, 1.0, 0.05, -10.0),
        samples=np.zeros((4, 4)),
        converged=True,
        tau_max=1.0,
        n_steps=10,
        n_walkers=8,
        prior=default_prior(px),
    )
    assert fit.pixels == px and not hasattr(fit, "levels")
    d = fit.to_dict()
    assert d["levels"] == list(px) and "pixels" not in d
    assert WeibullFit.from_dict(d).pixels == px
