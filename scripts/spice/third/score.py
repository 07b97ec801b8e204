#!/usr/bin/env python3
"""Score ``buckid diagnose`` on the third generator's converters.

Generates (or reuses, when both files exist) K cases per family x kind with ``third.py``,
runs ``buckid diagnose --data F --nominal switched --json F.diag.json`` (``--nominal averaged``
or none, the CLI's choice, with ``--nominal averaged|default``) on each (one at a
time, timed), and prints a markdown table per family and overall, then one line per case.

Scores (JSON fields checked against crates/buckid/src/diagnose.rs and crates/gap/src/lib.rs):

* withheld effects named: each effect of the truth's ``effects`` except ``sample_delay`` is
  named when it is among ``selected[].name`` (a ``param_drift`` when any drift is selected,
  whichever value it frees; the per-case lines show which);
* every effect of a case named (cases with at least one scored effect);
* ``dcm`` is named when selected, or when the diagnosis reports that its final model, a diode
  buck, starts more than 2 % of its periods in DCM (``dcm_share``: DCM is in the model's
  diode by construction, so it is reported as the regime, not as a step; 2 % is the share
  above which ``third.py`` lists ``dcm`` for a diode buck);
* ``none`` on clean cases: ``verdict == "none"``;
* true Cl inside the final CI95: the last of ``selected``: ``cl.estimate``, ``cl.ci95``;
  ``gap_before.cl``/``gap_before.cl_ci95`` when nothing is selected. An interval that is not
  finite, not positive or wider than a factor of 10 is a miss;
* median and max time of the diagnosis (wall clock of the process).

A second count, marked "dcm via diode_drop", also takes ``dcm`` as named whenever ``diode_drop``
is selected, whatever share of DCM periods the diagnosis reports.

Example:
    python scripts/spice/third/score.py --out /tmp/third --seed 7 --per-kind 2 --jobs 2
"""

import argparse
import concurrent.futures as cf
import json
import math
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
sys.path.insert(0, HERE)
import third  # noqa: E402


def case_seed(seed, j):
    return int(seed) * 100 + j + 1


def paths(out, family, kind, j):
    stem = os.path.join(out, f"{family}_{kind}_{j}")
    return stem + ".csv", stem + ".truth.json", stem + ".diag.json", stem + ".diag.log"


def generate_one(args):
    """Generate one case (in a worker); returns (stem, seconds, error)."""
    family, kind, j, seed, out, periods, noise_scale = args
    csv, truth, _, _ = paths(out, family, kind, j)
    if os.path.exists(csv) and os.path.exists(truth):
        return csv, 0.0, None
    clock = time.perf_counter()
    proc = subprocess.run([sys.executable, os.path.join(HERE, "third.py"), "--family", family, "--case", kind,
                           "--seed", str(case_seed(seed, j)), "--periods", str(periods),
                           "--noise-scale", repr(noise_scale),
                           "--out", csv + ".tmp", "--truth", truth + ".tmp"],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        return csv, time.perf_counter() - clock, proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "failed"
    os.replace(csv + ".tmp", csv)
    os.replace(truth + ".tmp", truth)
    return csv, time.perf_counter() - clock, None


def diagnose_one(buckid, csv, diag, log, nominal="switched"):
    clock = time.perf_counter()
    told = [] if nominal == "default" else ["--nominal", nominal]
    proc = subprocess.run([buckid, "diagnose", "--data", csv, *told, "--json", diag],
                          capture_output=True, text=True)
    seconds = time.perf_counter() - clock
    with open(log, "w") as fh:
        fh.write(proc.stdout + "\n--- stderr ---\n" + proc.stderr)
    if proc.returncode != 0 or not os.path.exists(diag):
        tail = (proc.stderr.strip() or proc.stdout.strip()).splitlines()
        return None, seconds, tail[-1] if tail else f"exit {proc.returncode}"
    with open(diag) as fh:
        return json.load(fh), seconds, None


def final_cl(dx):
    sel = dx.get("selected") or []
    if sel:
        cl = sel[-1]["cl"]
        return cl["estimate"], cl["ci95"]
    return dx["gap_before"]["cl"], dx["gap_before"]["cl_ci95"]


def interval_ok(ci):
    if ci is None or len(ci) != 2 or ci[0] is None or ci[1] is None:
        return False
    lo, hi = float(ci[0]), float(ci[1])
    return math.isfinite(lo) and math.isfinite(hi) and lo > 0 and hi > 0 and hi >= lo and hi / lo <= 10.0


# Share of a diode buck's periods in DCM above which third.py lists ``dcm`` (``dcm_fraction``).
DCM_SHARE = 0.02


def drifts_freed(dx):
    """The values (L, C, Rc) the selected ``param_drift`` steps free."""
    return {k for e in dx.get("selected") or [] if e["name"] == "param_drift" for k in ("L", "C", "Rc") if k in e.get("params", {})}


def score_case(truth, dx, lenient_dcm=False, strict_drift=False, alike=False):
    """(scored effects, named flags, all named, none ok or None, Cl in CI, Cl estimate, ci).

    With ``alike`` an effect also counts where a selected step says the data does not tell it
    from the effect that step took (its ``alike`` list): told, if not as the one taken.

    ``param_drift`` counts as named when a drift is selected, whichever value it frees; with
    ``strict_drift`` only when it frees a value the generator drew drifted (an L drift named
    where C drifted is the wrong effect to an engineer)."""
    effects = [e for e in truth["effects"] if e != "sample_delay"]
    names = [e["name"] for e in dx.get("selected") or []]
    if alike:
        names += [a["name"] for e in dx.get("selected") or [] for a in e.get("alike") or []]
    flags = []
    for e in effects:
        if e == "dcm" and lenient_dcm:
            flags.append("dcm" in names or "diode_drop" in names)
        elif e == "dcm":
            flags.append("dcm" in names or (dx.get("dcm_share") or 0.0) > DCM_SHARE)
        elif e == "param_drift" and strict_drift:
            flags.append(bool(drifts_freed(dx) & set(truth.get("drifted") or [])))
        else:
            flags.append(e in names)
    cl, ci = final_cl(dx)
    inside = interval_ok(ci) and float(ci[0]) <= truth["cl_true"] <= float(ci[1])
    none_ok = (dx.get("verdict") == "none") if truth["kind"] == "clean" else None
    return effects, flags, (all(flags) if effects else None), none_ok, inside, cl, ci


def labels(dx):
    out = []
    for e in dx.get("selected") or []:
        name = e["name"]
        if name == "param_drift":
            freed = [k for k in ("L", "C", "Rc") if k in e.get("params", {})]
            name += f" ({freed[0]})" if freed else ""
        out.append(name)
    if dx.get("dcm_share") is not None:
        out.append(f"(DCM in {100 * dx['dcm_share']:.0f} % of periods)")
    return out


def si(x, unit="F"):
    if x is None or not isinstance(x, (int, float)) or not math.isfinite(x):
        return "nan"
    for scale, p in ((1e-12, "p"), (1e-9, "n"), (1e-6, "µ"), (1e-3, "m"), (1.0, "")):
        # (Below what rounds to 1000 in three digits: 1 µF is "1 µF", not "1e+03 nF".)
        if abs(x / scale) < 999.5:
            return f"{x / scale:.3g} {p}{unit}"
    return f"{x:.3g} {unit}"


def interval(ci):
    """A CI95 as the report prints it: `[lo, hi]`, or "(not identified)" where a bound is
    missing, not finite or not positive (never `[0, inf]`)."""
    bounds = [x for x in (ci or []) if isinstance(x, (int, float)) and math.isfinite(x) and x > 0]
    return f"[{si(bounds[0])}, {si(bounds[1])}]" if len(bounds) == 2 else "(not identified)"


def pct(a, b):
    return f"{100.0 * a / b:.0f} % ({a}/{b})" if b else "–"


def table(rows, title):
    eff_total = sum(len(r["effects"]) for r in rows if r["dx"])
    eff_named = sum(sum(r["flags"]) for r in rows if r["dx"])
    eff_named_l = sum(sum(r["flags_l"]) for r in rows if r["dx"])
    eff_named_s = sum(sum(r["flags_s"]) for r in rows if r["dx"])
    eff_told = sum(sum(r["flags_t"]) for r in rows if r["dx"])
    cases_eff = [r for r in rows if r["dx"] and r["effects"]]
    all_named = sum(1 for r in cases_eff if r["all"])
    all_named_l = sum(1 for r in cases_eff if r["all_l"])
    clean = [r for r in rows if r["kind"] == "clean" and r["dx"]]
    none_ok = sum(1 for r in clean if r["none_ok"])
    done = [r for r in rows if r["dx"]]
    cl_in = sum(1 for r in done if r["cl_in"])
    times = [r["seconds"] for r in rows if r["seconds"] is not None]
    errors = sum(1 for r in rows if r["error"])
    lines = [f"### {title}", "", "| score | value |", "|---|---|",
             f"| withheld effects named (`sample_delay` set aside) | {pct(eff_named, eff_total)} |",
             f"| … with `dcm` counted via `diode_drop` | {pct(eff_named_l, eff_total)} |",
             f"| … with `param_drift` counted only for the value drawn drifted | {pct(eff_named_s, eff_total)} |",
             f"| … named or said alike to an effect named (the data does not tell them apart) | {pct(eff_told, eff_total)} |",
             f"| every effect of a case named | {pct(all_named, len(cases_eff))} |",
             f"| … with `dcm` counted via `diode_drop` | {pct(all_named_l, len(cases_eff))} |",
             f"| `none` on clean cases | {pct(none_ok, len(clean))} |",
             f"| true Cl inside the final CI95 | {pct(cl_in, len(done))} |",
             f"| diagnosis time | median {statistics.median(times):.2f} s, max {max(times):.2f} s |" if times else "| diagnosis time | – |",
             f"| diagnosis errors | {errors} |", ""]
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="directory for the cases, their truths and diagnoses")
    p.add_argument("--seed", type=int, default=7)
    p.add_argument("--per-kind", type=int, default=2)
    p.add_argument("--families", default="thesis,lab,pol")
    p.add_argument("--kinds", default="clean,single,several")
    p.add_argument("--jobs", type=int, default=2, help="parallel generations (diagnoses run one at a time)")
    p.add_argument("--periods", type=int, default=3001)
    p.add_argument("--noise-scale", type=float, default=1.0,
                   help="scale every case's drawn sensor noise (0.1: a quiet bench)")
    p.add_argument("--buckid", default=os.path.join(ROOT, "target", "release", "buckid"))
    p.add_argument("--nominal", choices=("switched", "averaged", "default"), default="switched",
                   help="the diagnosis's nominal model (default: none named, the CLI chooses)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    families = [f for f in a.families.split(",") if f]
    kinds = [k for k in a.kinds.split(",") if k]
    jobs = [(f, k, j, a.seed, a.out, a.periods, a.noise_scale) for f in families for k in kinds for j in range(a.per_kind)]
    gen_err, gen_time = {}, {}
    clock = time.perf_counter()
    with cf.ProcessPoolExecutor(max_workers=max(1, a.jobs)) as pool:
        for (f, k, j, *_), (csv, secs, err) in zip(jobs, pool.map(generate_one, jobs)):
            gen_time[(f, k, j)] = secs
            if err:
                gen_err[(f, k, j)] = err
            print(f"generated {os.path.basename(csv)} in {secs:.1f} s" + (f": ERROR {err}" if err else ""),
                  file=sys.stderr, flush=True)
    print(f"generation: {time.perf_counter() - clock:.0f} s wall", file=sys.stderr)
    rows = []
    for f, k, j, *_ in jobs:
        csv, truth_path, diag, log = paths(a.out, f, k, j)
        row = dict(family=f, kind=k, j=j, dx=None, seconds=None, error=gen_err.get((f, k, j)), effects=[], flags=[],
                   flags_l=[], flags_s=[], flags_t=[], all=None, all_l=None, none_ok=None, cl_in=False, truth=None)
        rows.append(row)
        if row["error"]:
            row["error"] = "generation: " + row["error"]
            continue
        with open(truth_path) as fh:
            truth = json.load(fh)
        row["truth"] = truth
        dx, secs, err = diagnose_one(a.buckid, csv, diag, log, a.nominal)
        row.update(seconds=secs, error=err, dx=dx)
        print(f"diagnosed {os.path.basename(csv)} in {secs:.2f} s" + (f": ERROR {err}" if err else ""),
              file=sys.stderr, flush=True)
        if dx:
            effects, flags, all_, none_ok, inside, cl, ci = score_case(truth, dx)
            _, flags_l, all_l, _, _, _, _ = score_case(truth, dx, lenient_dcm=True)
            flags_s = score_case(truth, dx, strict_drift=True)[1]
            flags_t = score_case(truth, dx, alike=True)[1]
            row.update(effects=effects, flags=flags, flags_l=flags_l, flags_s=flags_s, flags_t=flags_t, all=all_, all_l=all_l, none_ok=none_ok,
                       cl_in=inside, cl=cl, ci=ci)
    out = [f"## buckid diagnose on the third generator (seed {a.seed}, {a.per_kind} per family and kind)", ""]
    for f in families:
        out.append(table([r for r in rows if r["family"] == f], f"family `{f}`"))
    out.append(table(rows, "all families"))
    out.append("### cases\n")
    for r in rows:
        t = r["truth"]
        head = f"- `{r['family']}/{r['kind']}/{r['j']}`"
        if t is None:
            out.append(f"{head}: {r['error']}")
            continue
        eff = ", ".join(t["effects"]) or "none"
        sel = ", ".join(labels(r["dx"])) if r["dx"] else "–"
        topo = f"{t['topology']}, {t['drive']['kind']}"
        extra = []
        if not t["acq"]["with_il"]:
            extra.append("no il")
        if t.get("drifted"):
            extra.append("drift " + "/".join(f"{x} {100 * (t['circuit'][x] / t['nominal'][x] - 1):+.0f} %" for x in t["drifted"]))
        if r["dx"]:
            cl = f"Cl {si(r['cl'])} {interval(r['ci'])} vs {si(t['cl_true'])} {'✓' if r['cl_in'] else '✗'}"
            named = f"{sum(r['flags'])}/{len(r['effects'])} named"
            verdict = r["dx"].get("verdict")
        else:
            cl, named, verdict = "", "", ""
        timing = f"{r['seconds']:.2f} s" if r["seconds"] is not None else ""
        err = f"; ERROR: {r['error']}" if r["error"] else ""
        out.append(f"{head} ({topo}{'; ' + ', '.join(extra) if extra else ''}): {eff} → {sel or 'none'} "
                   f"(verdict {verdict}; {named}); {cl}; {timing}{err}")
    slow = [r for r in rows if r["seconds"] is not None and r["seconds"] > 2.0]
    out.append("")
    out.append(f"diagnoses over 2 s: {len(slow)}" + (": " + ", ".join(f"{r['family']}/{r['kind']}/{r['j']} {r['seconds']:.2f} s" for r in slow) if slow else ""))
    errs = [r for r in rows if r["error"]]
    out.append(f"errors: {len(errs)}" + ("".join(f"\n- {r['family']}/{r['kind']}/{r['j']}: {r['error']}" for r in errs) if errs else ""))
    gen = [v for v in gen_time.values() if v > 0]
    if gen:
        out.append(f"generation time per case (this run, {a.jobs} in parallel): median {statistics.median(gen):.0f} s, max {max(gen):.0f} s")
    print("\n".join(out))


if __name__ == "__main__":
    main()
