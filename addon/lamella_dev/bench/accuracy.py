"""`lamella references` and `lamella bench accuracy`: every model against the stochastic reference
on the suite (``lamella_dev.suite``), BRDF space.

References are computed once (``compute_references``) and stored compressed, one ``.npz`` per
suite case, with the command that made them; the table is then rebuilt from them in seconds.
Two yardsticks are kept: rough interfaces scattering once (``REFERENCE_DIR``, pbrt-v4's
convention) and scattering as often as the microsurface makes them (``REFERENCE_DIR_MULTIPLE``,
Heitz et al. 2016: energy conserving, ``reference_dir``).
"""
from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np

from lamella.core import api
from .. import reference, suite
from ..metrics import albedo_error, relative_l1
from lamella.core.models import MODELS as REGISTRY
from lamella.core.models import UnsupportedStack
from lamella.core.stack import Stack
from .paths import BENCH_DIR, REFERENCE_DIR, REFERENCE_DIR_MULTIPLE
from .page import write_page
from .registry import Bench, register

MODELS = (*REGISTRY, "auto")  # every registered model, then auto


def reference_dir(interfaces: str) -> Path:
    """Where the references of rough interfaces scattering ``interfaces`` ("single", "multiple") live."""
    return REFERENCE_DIR_MULTIPLE if interfaces == "multiple" else REFERENCE_DIR


def _angle_arrays(stack, deg: float, spp: int, albedo_spp: int, seed: int, interfaces: str) -> dict:
    """One incidence of a stored reference: its arrays without the index suffix (``wo``, ``mean``,
    ... and the transmitted side's for a dielectric base). The seeds are offset by the angle's
    position in ``suite.REFERENCE_ANGLES``."""
    k = 1000 * suite.REFERENCE_ANGLES.index(deg)
    wi = suite.incident(deg)
    wo, weight = suite.wo_grid(wi)
    mean, err = reference.eval_brdf_cos(stack, wi, wo, spp=spp, seed=seed + k, interfaces=interfaces)
    amean, aerr = reference.albedo(stack, wi, spp=albedo_spp, seed=seed + k + 1, interfaces=interfaces)
    out = {"wo": wo, "weight": weight, "mean": mean, "stderr": err,
           "albedo": np.asarray(amean).reshape(3), "albedo_stderr": np.asarray(aerr).reshape(3)}
    if stack.base.kind.transmits:  # light crossing the base: the transmitted side
        wo, weight = suite.wo_grid_transmitted(wi)
        mean, err = reference.eval_brdf_cos(stack, wi, wo, spp=spp, seed=seed + k + 2, interfaces=interfaces)
        amean, aerr = reference.albedo(stack, wi, spp=albedo_spp, seed=seed + k + 3, side="transmitted",
                                      interfaces=interfaces)
        out.update({"wo_t": wo, "weight_t": weight, "mean_t": mean, "stderr_t": err,
                    "albedo_t": np.asarray(amean).reshape(3), "albedo_t_stderr": np.asarray(aerr).reshape(3)})
    return out


def _split_angles(data: dict) -> dict[float, dict]:
    """A stored reference's arrays per incidence (the inverse of how ``compute_references`` stores them)."""
    per = {}
    for i, deg in enumerate(data["wi_degrees"]):
        suffix = f"_{i}"
        per[float(deg)] = {k[: -len(suffix)]: v for k, v in data.items() if k.endswith(suffix) and k[: -len(suffix)]
                           in ANGLE_KEYS}
    return per


ANGLE_KEYS = ("wo", "weight", "mean", "stderr", "albedo", "albedo_stderr",
              "wo_t", "weight_t", "mean_t", "stderr_t", "albedo_t", "albedo_t_stderr")


def compute_references(cases=None, spp: int = 2048, albedo_spp: int = 1 << 18, seed: int = 1,
                       out_dir: Path | None = None, command: str = "", progress=print,
                       interfaces: str = "single", angles=None) -> list[Path]:
    """Compute and store the references of ``cases`` at the incidences ``angles`` (default
    ``suite.WI_DEGREES``). Angles outside the default are added to a stored reference (its other
    angles kept, the added ones recorded in its meta with their walkers and command)."""
    out_dir = reference_dir(interfaces) if out_dir is None else out_dir
    out_dir.mkdir(parents=True, exist_ok=True)
    angles = tuple(float(a) for a in (angles or suite.WI_DEGREES))
    unknown = [a for a in angles if a not in suite.REFERENCE_ANGLES]
    if unknown:
        raise ValueError(f"incidence {unknown} is not one of suite.REFERENCE_ANGLES {suite.REFERENCE_ANGLES}")
    written = []
    for name in cases or suite.names():
        stack = suite.load(name)
        path = out_dir / f"{name}.npz"
        add = set(angles) != set(suite.WI_DEGREES)
        per: dict[float, dict] = {}
        meta: dict = {}
        if add:
            if not path.exists():
                raise FileNotFoundError(f"{path}: compute the reference at {suite.WI_DEGREES} first")
            old = load_reference(name, out_dir)
            meta = old.pop("meta")
            if Stack.from_dict(meta["stack"]) != stack or meta.get("interfaces", "single") != interfaces:
                raise ValueError(f"{path}: stored for another stack or interface setting")
            per = _split_angles(old)
        t0 = time.time()
        for deg in angles:
            per[deg] = _angle_arrays(stack, deg, spp, albedo_spp, seed, interfaces)
        cmd = command or f"lamella references --cases {name} --spp {spp}"
        if add:
            meta.setdefault("added", []).append({"wi_degrees": list(angles), "spp": spp, "command": cmd,
                                                 "seconds": round(time.time() - t0, 1)})
        else:
            meta = {"case": name, "stack": stack.to_dict(), "spp": spp, "albedo_spp": albedo_spp, "seed": seed,
                    "interfaces": interfaces, "command": cmd,
                    "seconds": round(time.time() - t0, 1), "machine": platform.machine()}
        data: dict[str, np.ndarray] = {"wi_degrees": np.array(sorted(per))}
        for i, deg in enumerate(sorted(per)):
            data.update({f"{k}_{i}": v for k, v in per[deg].items()})
        data["meta"] = np.array(json.dumps(meta))
        np.savez_compressed(path, **data)
        written.append(path)
        progress(f"{name}: {round(time.time() - t0, 1)} s -> {path}")
    return written


def load_reference(name: str, ref_dir: Path = REFERENCE_DIR) -> dict:
    with np.load(ref_dir / f"{name}.npz") as z:
        d = {k: z[k] for k in z.files}
    d["meta"] = json.loads(str(d["meta"]))
    return d


def reference_noise(ref: dict, i: int) -> float:
    """The reference's own noise on the relative L1 metric at its i-th incidence: the sum of its
    standard errors relative to the signal, RGB averaged."""
    w = ref[f"weight_{i}"]
    return float(np.mean((ref[f"stderr_{i}"] * w[:, None]).sum(0)
                         / np.maximum((ref[f"mean_{i}"] * w[:, None]).sum(0), 1e-30)))


def isotropic(stack) -> bool:
    """Every rough layer has the same roughness along both axes (so the stack's BRDF is symmetric
    about the plane of incidence, and about the normal at normal incidence)."""
    layers = list(stack.coats) + ([stack.base] if hasattr(stack.base, "roughness") else [])
    return all(layer.roughness[0] == layer.roughness[1] for layer in layers)


def _orbits(wi: np.ndarray, wo: np.ndarray, symmetry: str, n_theta: int = 16, n_phi: int = 24) -> np.ndarray:
    """For directions of ``suite.wo_grid(wi)`` (upper hemisphere), a label per direction shared by
    the directions the stack's BRDF cannot tell apart: ``"ring"`` every azimuth of a ring about the
    normal, ``"mirror"`` the mirror image through the plane of incidence (half-vector azimuth cell
    k and n_phi - 1 - k), ``"half_turn"`` the direction turned by 180 degrees about the normal
    (cell k and k + n_phi / 2)."""
    h = wi[None, :] + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    t = np.sqrt(np.arccos(np.clip(h[:, 2], -1.0, 1.0)) / (0.5 * np.pi))
    ti = np.clip(np.rint(t * n_theta - 0.5), 0, n_theta - 1).astype(int)
    phi = np.mod(np.arctan2(h[:, 1], h[:, 0]), 2.0 * np.pi)
    pk = np.mod(np.rint(phi / (2.0 * np.pi) * n_phi - 0.5), n_phi).astype(int)
    if symmetry == "ring":
        return ti
    if symmetry == "mirror":
        return ti * n_phi + np.minimum(pk, n_phi - 1 - pk)
    if symmetry == "half_turn":
        return ti * n_phi + pk % (n_phi // 2)
    raise ValueError(f"unknown symmetry {symmetry!r}")


def symmetrized(mean: np.ndarray, stderr: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A reference averaged over the directions of each label (exact symmetries of the stack):
    the same expectation, a smaller standard error (that of the average of independent estimates)."""
    out_m, out_e = np.empty_like(mean), np.empty_like(stderr)
    for lab in np.unique(labels):
        sel = labels == lab
        out_m[sel] = mean[sel].mean(0)
        out_e[sel] = np.sqrt((stderr[sel] ** 2).sum(0)) / sel.sum()
    return out_m, out_e


def symmetry(stack, deg: float) -> str | None:
    """The symmetry of the stack's BRDF at incidence ``deg`` in the plane of the shading tangent
    (``_orbits``). Every layer's GGX distribution is unchanged by a half turn about the normal, so
    at normal incidence any stack is; an isotropic stack is also symmetric about the plane of
    incidence, and at normal incidence about the normal."""
    if isotropic(stack):
        return "ring" if deg == 0.0 else "mirror"
    return "half_turn" if deg == 0.0 else None


def reference_by_symmetry(ref: dict, i: int, stack, side: str = "") -> tuple[np.ndarray, np.ndarray]:
    """The stored reference's mean and standard error at its i-th incidence (``side`` "_t": the
    transmitted side), averaged over the directions the stack cannot tell apart (``symmetry``; the
    walkers of each direction are independent, so this only lowers the noise)."""
    mean, err = ref[f"mean{side}_{i}"], ref[f"stderr{side}_{i}"]
    deg = float(ref["wi_degrees"][i])
    kind = symmetry(stack, deg)
    if kind is None:
        return mean, err
    wo = ref[f"wo{side}_{i}"] * (np.array([1.0, 1.0, -1.0]) if side else 1.0)  # transmitted: the mirrored grid
    return symmetrized(mean, err, _orbits(suite.incident(deg), wo, kind))


def evaluate_case(name: str, ref: dict, models=MODELS, stack=None, cache: dict | None = None) -> list[dict]:
    """Rows of (model, wi, relative L1, albedo error, noise floor) for one suite case (or for
    ``stack`` under that name). An isotropic stack's reference is first averaged over the
    directions it cannot tell apart (``reference_by_symmetry``). ``cache``: a dict the caller
    passes again for another reference of the same stack (the two yardsticks share their
    directions): the models' values at the same directions are computed once."""
    stack = suite.load(name) if stack is None else stack
    cache = {} if cache is None else cache

    def model_values(m, deg, wi, wo, side="reflected"):
        key = (m, float(deg), side, wo.shape, wo.tobytes())
        if key not in cache:  # deltas: compared through the albedo
            cache[key] = api.evaluate(stack, wi, wo, m, deltas=False)
        if (m, float(deg), side) not in cache:  # the albedo does not depend on the grid
            cache[(m, float(deg), side)] = api.albedo(stack, wi, m, side=side)[0]
        return cache[key], cache[(m, float(deg), side)]

    rows = []
    for i, deg in enumerate(ref["wi_degrees"]):
        wi = suite.incident(float(deg))
        wo, weight = ref[f"wo_{i}"], ref[f"weight_{i}"]
        f_ref, err = reference_by_symmetry(ref, i, stack)
        a_ref = ref[f"albedo_{i}"]
        noise = float(np.mean((err * weight[:, None]).sum(0) / np.maximum((f_ref * weight[:, None]).sum(0), 1e-30)))
        for m in models:
            try:
                f, a = model_values(m, deg, wi, wo)
            except UnsupportedStack as e:
                rows.append({"case": name, "model": m, "wi": float(deg), "unsupported": str(e)})
                continue
            row = {"case": name, "model": m, "wi": float(deg),
                   "rel_l1": relative_l1(f, f_ref, weight), "albedo_err": albedo_error(a, a_ref),
                   "ref_noise": noise, "albedo": a.tolist(), "albedo_ref": a_ref.tolist()}
            if f"wo_t_{i}" in ref:  # a dielectric base: the transmitted side too
                ft, at = model_values(m, deg, wi, ref[f"wo_t_{i}"], "transmitted")
                row.update({"rel_l1_t": relative_l1(ft, reference_by_symmetry(ref, i, stack, "_t")[0],
                                                    ref[f"weight_t_{i}"]),
                            "albedo_err_t": albedo_error(at, ref[f"albedo_t_{i}"])})
            rows.append(row)
    return rows


PENDING_DIR = REFERENCE_DIR.parent / "brdf_pending"


def run(ref_dir: Path = REFERENCE_DIR, out_dir: Path = BENCH_DIR, models=MODELS,
        pending_dir: Path = PENDING_DIR, multiple_dir: Path = REFERENCE_DIR_MULTIPLE) -> tuple[Path, Path]:
    """Every suite case against both yardsticks (``rows``: single-scattering interfaces;
    ``rows_multiple``: multiple-scattering interfaces, where stored), then the cases whose BRDF
    reference is stored in ``pending_dir`` but which are not in the suite yet (waiting for their
    image references), marked ``pending``."""
    rows, rows_multiple = [], []
    for name in suite.names():
        if not (ref_dir / f"{name}.npz").exists():
            raise FileNotFoundError(f"no stored reference for {name}: run `lamella references --cases {name}`")
        cache: dict = {}  # the models' values, shared by the two yardsticks of this case
        rows.extend(evaluate_case(name, load_reference(name, ref_dir), models, cache=cache))
        # the energy-conserving yardstick, for the cases whose reference is stored
        if (multiple_dir / f"{name}.npz").exists():
            rows_multiple.extend(evaluate_case(name, load_reference(name, multiple_dir), models, cache=cache))
    for path in sorted(pending_dir.glob("*.npz")) if pending_dir.exists() else []:
        if path.stem not in suite.names():
            rows.extend({**r, "pending": True} for r in evaluate_case(path.stem, load_reference(path.stem, pending_dir),
                                                                      models))
    floor = floors(out_dir)
    mpath = write_page(out_dir, "accuracy", lambda: format_markdown(rows, models, rows_multiple, floor),
                       {"models": list(models), "wi_degrees": list(suite.WI_DEGREES), "rows": rows,
                        "rows_multiple": rows_multiple,
                        "floors": [{"case": c, "wi": w, "floor": v} for (c, w), v in floor.items()]})
    return mpath, mpath.with_suffix(".json")


def floors(page_dir: Path = BENCH_DIR) -> dict[tuple[str, float], float]:
    """(case, incidence) -> the floor of ``auto``'s lobes against the energy-conserving reference,
    as the last `lamella bench lobe-floor` stored it in ``page_dir`` (empty when it has not run there).
    The accuracy page stores the floors it showed (``stored_floors``)."""
    path = Path(page_dir) / "lobe_floor.json"
    if not path.exists():
        return {}
    data = json.loads(path.read_text(encoding="utf-8"))
    return {(r["case"], r["wi"]): r["rel_l1_floor"] for r in data.get("paths", [])} if isinstance(data, dict) else {}


def stored_floors(data: dict) -> dict[tuple[str, float], float]:
    """The floors an accuracy page's stored measurements (``bench/accuracy.json``) were shown with."""
    return {(r["case"], r["wi"]): r["floor"] for r in data.get("floors", [])}


def median_table(rows: list[dict], models, wis) -> list[str]:
    """Per model and incidence, the suite's median relative L1 / median albedo error (reflected side)."""
    lines = ["| model | " + " | ".join(f"{w:g}°" for w in wis) + " | cases |", "|---|" + "---|" * (len(wis) + 1)]
    for m in models:
        cells = []
        for w in wis:
            rs = [r for r in rows if r["model"] == m and r["wi"] == w and "rel_l1" in r and not r.get("pending")]
            cells.append(f"{np.median([r['rel_l1'] for r in rs]):.3f} / {np.median([r['albedo_err'] for r in rs]):.3f}"
                         if rs else "unsupported")
        n = len({r["case"] for r in rows if r["model"] == m and "rel_l1" in r and not r.get("pending")})
        lines.append(f"| {m} | " + " | ".join(cells) + f" | {n} |")
    return lines


def _case_tables(rows: list[dict], models, wis, desc, floors: dict | None = None) -> list[str]:
    """Per case, a table of every model's relative L1 / albedo error per incidence; with ``floors``
    ((case, incidence) -> the floor of ``auto``'s lobes, ``floors``) two more columns:
    that floor and ``auto`` minus it, the model's own error."""
    from lamella.core.models import choose_auto

    floors = floors or {}
    lines = []
    for name in dict.fromkeys(r["case"] for r in rows):
        with_floor = any((name, w) in floors for w in wis)
        lines += [f"### {name}", "", desc.get(name, "") + f" `auto` runs {choose_auto(suite.load(name))}.", ""]
        extra = " floor | auto − floor |" if with_floor else ""
        lines.append("| wi | " + " | ".join(models) + " | noise |" + extra)
        lines.append("|---|" + "---|" * (len(models) + 1 + 2 * with_floor))
        for w in wis:
            cells = {r["model"]: r for r in rows if r["case"] == name and r["wi"] == w}
            l1s = {m: cells[m]["rel_l1"] for m in models if m != "auto" and "rel_l1" in cells.get(m, {})}
            best = min(l1s, key=l1s.get) if l1s else None
            out = []
            for m in models:
                r = cells.get(m, {})
                if "rel_l1" not in r:
                    out.append("unsupported")
                    continue
                s = f"{r['rel_l1']:.3f} / {r['albedo_err']:.3f}"
                out.append(f"**{s}**" if m == best else s)
            noise = next((r["ref_noise"] for r in cells.values() if "ref_noise" in r), float("nan"))
            tail = ""
            if with_floor:
                floor = floors.get((name, w))
                auto = cells.get("auto", {}).get("rel_l1")
                tail = (f" {floor:.3f} | **{auto - floor:.3f}** |" if floor is not None and auto is not None
                        else " | |")
            lines.append(f"| {w:g}° | " + " | ".join(out) + f" | {noise:.3f} |" + tail)
            if any("rel_l1_t" in r for r in cells.values()):
                out = [f"{cells[m]['rel_l1_t']:.3f} / {cells[m]['albedo_err_t']:.3f}" if "rel_l1_t" in cells.get(m, {})
                       else "unsupported" for m in models]
                lines.append(f"| {w:g}° T | " + " | ".join(out) + " | |" + " | |" * with_floor)
        lines.append("")
    return lines


def _glass_plate_reading(rows: list[dict], case: str = "rough_glass_plate", ours: str = "endf",
                         adding: str = "yamaguchi2019") -> str:
    """Why ``auto`` runs ``endf`` on glass, from the rows the page shows: the glass plate's mean
    relative L1 over the angles, transmitted and reflected side, against the adding family's."""
    def mean(model, key):
        values = [r[key] for r in rows if r["case"] == case and r["model"] == model and key in r]
        return float(np.mean(values)) if values else None

    t_ours, t_adding, r_ours, r_adding = mean(ours, "rel_l1_t"), mean(adding, "rel_l1_t"), mean(ours, "rel_l1"), \
        mean(adding, "rel_l1")
    if None in (t_ours, t_adding, r_ours, r_adding):
        return "the transmitted side of the glass plate (per case, below)"
    return (f"the transmitted side of the glass plate at {t_ours:.2f} mean relative L1 against {t_adding:.2f} "
            f"({adding}), the reflected side {r_ours:.2f} against {r_adding:.2f}")


def format_markdown(rows: list[dict], models, rows_multiple: list[dict] | None = None,
                    floors: dict | None = None) -> str:
    desc = {**suite.pending_descriptions(), **suite.descriptions()}
    wis = sorted({r["wi"] for r in rows})
    rows_multiple = rows_multiple or []
    lines = [
        "# BRDF accuracy against the stochastic reference",
        "",
        "Two yardsticks (`lamella_dev.reference`, `interfaces=`): rough interfaces that scatter as often as",
        "their microsurface makes them (Heitz, Hanika, d'Eon and Dachsbacher 2016; energy conserving, references",
        "in `tests/references/brdf_multiple/`, `lamella references --interfaces multiple`), and rough interfaces",
        "that scatter once (pbrt-v4's convention, which loses the energy a microsurface scatters again; references",
        "in `tests/references/brdf/`). The models conserve energy (T = 1 - R), so the first is the one to",
        "measure them by; the second is kept for continuity.",
        "",
        "## Summary: the suite's median per incidence (relative L1 / albedo error, reflected side)",
        "",
    ]
    if rows_multiple:
        n = len({r["case"] for r in rows_multiple})
        lines += [f"Against **multiple-scattering** interfaces ({n} of {len({r['case'] for r in rows})} cases stored):", ""]
        lines += median_table(rows_multiple, models, sorted({r["wi"] for r in rows_multiple})) + [""]
    lines += ["Against **single-scattering** interfaces:", ""] + median_table(rows, models, wis) + [""]
    lines += [
        "## Per case",
        "",
        "Generated by `lamella bench accuracy` from the stored references (made by `lamella references`).",
        "Each cell: **relative L1** of f·cos over a half-vector",
        "hemisphere grid (`lamella_dev.suite.wo_grid`) / **relative albedo error**, RGB averaged,",
        "at incidence zenith angles " + ", ".join(f"{w:g}°" for w in wis) + ".",
        "`noise` is the reference's own stderr on the L1 metric (a floor below which differences are",
        "not resolved). Best model per row in bold (`auto` is the model it picks, see below).",
        "",
        "`auto` is a pure function of the stack's structure (`lamella.core.models.choose_auto`):",
        "",
        "| stack | auto runs | why |",
        "|---|---|---|",
        "| any coat scatters (sigma_s > 0) | tm6_refined | forward and back-scattered fluxes by tm6 (the adding "
        "family's Belcour 2018 medium operator keeps single forward scattering only), the light no medium "
        "scattered by yamaguchi_refined (`docs/models.md`) |",
        "| one isotropic coat over an isotropic dielectric base | endf | exact Jacobians of both refractions: "
        + _glass_plate_reading(rows_multiple or rows) + " |",
        "| interfaces and absorbing coats, any base | yamaguchi_refined | the 2x2 covariance follows rotated "
        "anisotropy; Yamaguchi et al. 2019 with the refinements of `bench/interface_variants.md`, best or tied on "
        "these cases |",
        "",
    ]
    if rows_multiple:
        lines += ["## Against multiple-scattering interfaces", ""]
        if floors:
            lines += ["*floor*: `auto`'s lobes with every energy and roughness fitted to this reference, the error no "
                      "choice of them removes (`bench/lobe_floor.md`, from its last run); *auto − floor*: the model's own "
                      "error, what better energies and roughnesses can still remove.", ""]
        lines += _case_tables(rows_multiple, models, sorted({r["wi"] for r in rows_multiple}), desc, floors)
        lines += ["## Against single-scattering interfaces", ""]
    lines += _case_tables([r for r in rows if not r.get("pending")], models, wis, desc)
    pending = [r for r in rows if r.get("pending")]
    if pending:
        lines += ["# Media, diffuse and glass bases, ENDF-sized coats (awaiting image references)", "",
                  "BRDF references stored in `tests/references/brdf_pending/` (`lamella references --cases ...`);",
                  "these cases join the suite with their image references. A `T` row is the transmitted side of",
                  "a dielectric base (f·|cos| below the surface / transmitted albedo).", ""]
        lines += _case_tables(pending, models, wis, desc)
    for title, group in (("all suite cases", [r for r in rows if not r.get("pending")]),
                         ("the cases awaiting image references", [r for r in rows if r.get("pending")])):
        if not group:
            continue
        lines += [f"## Summary (mean over {title} and angles, reflected side)", "",
                  "| model | mean rel. L1 | worst rel. L1 | worst case | cases supported |", "|---|---|---|---|---|"]
        n_cases = len({r["case"] for r in group})
        for m in models:
            rs = [r for r in group if r["model"] == m and "rel_l1" in r]
            if not rs:
                lines.append(f"| {m} | unsupported | | | 0 / {n_cases} |")
                continue
            worst = max(rs, key=lambda r: r["rel_l1"])
            lines.append(f"| {m} | {np.mean([r['rel_l1'] for r in rs]):.3f} | {worst['rel_l1']:.3f} | "
                         f"{worst['case']} at {worst['wi']:g}° | {len({r['case'] for r in rs})} / {n_cases} |")
        lines.append("")
    return "\n".join(lines)


BENCH = register(Bench("accuracy", "every model against the suite's stored BRDF references",
                       lambda out_dir, args: run(out_dir=out_dir)[0]))
