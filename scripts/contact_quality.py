"""``python -m scripts.contact_quality RUN_DIR [RUN_DIR ...]``: contact errors against the truth, by
the shape under the pad (issue 11).

For every contact a run recorded (or, with ``--replay``, measured again from the session by the
current pipeline), the distance to the true surface and the angle to the true normal, binned by the
distance of the true closest point to the nearest sharp edge and by the turn of the true normal
under the pad (:mod:`explorer.contact_truth`), by how far past its target the touch went (a probe
that passed the GPIS's guessed surface meets the true one at an angle the guess did not predict),
by the angle between the approach and the true normal, and by the press's peak force over the
loop's press force (a press that ran out of depth short of it met the surface with the pad's rim
or side). Each bin also gives its share of all contacts' squared position error. Also the contacts
the pipeline flagged as doubtful and the realign touches. Simulated runs only (the truth is the
run's object).

Options: ``--replay recorded|pad-centre|current`` measures the contacts again from the session, as
recorded, at the pad-face centre (the pipeline before issue 11), or with the current pipeline and
the default doubtful-contact and realign rules (a session recorded before issue 11 then keeps its
touch sequence: approximate); ``--compliance MM_PER_N`` replays with that pad compliance instead of
the recorded one (the contacts' offset from the surface then shows what it changes: the summary
gives their median signed offset and its slope against the force); ``--csv FILE`` writes one row per
contact; ``--json FILE`` the summary.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np



def parse_args(argv=None):
    parser = argparse.ArgumentParser(prog="python -m scripts.contact_quality", description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories (each with session/)")
    parser.add_argument("--replay", choices=("recorded", "pad-centre", "current"),
                        help="measure the contacts again from the session with this pipeline")
    parser.add_argument("--compliance", type=float, metavar="MM_PER_N",
                        help="with --replay: the pad's compliance to measure with, mm per newton")
    parser.add_argument("--csv", type=Path, help="write one row per contact here")
    parser.add_argument("--json", type=Path, help="write the summary here")
    args = parser.parse_args(argv)
    if args.compliance is not None and (args.replay is None or not args.compliance >= 0.0):
        parser.error("--compliance needs --replay and a compliance >= 0 mm/N, e.g. --replay recorded --compliance 0.136")
    for run in args.runs:
        if not (run / "session" / "metadata.json").is_file() and not (run / "metadata.json").is_file():
            parser.error(f"{run}: not a run directory (no session/metadata.json); give the --out of a run")
    return args


def run_contacts(run: Path, replay: str | None, compliance_m_per_n: float | None = None) -> tuple[str, list[dict]]:
    """The object name and one dict per pressed touch with a contact (kind, position, normal, quality)."""
    from explorer.session import SessionReader

    session = run / "session" if (run / "session").is_dir() else run
    metadata = SessionReader(session).metadata
    if replay:
        from explorer.replay import SessionReplay

        from explorer.contact import ContactPipeline, DoubtRule
        from explorer.loop import LoopConfig

        replayer = SessionReplay(session)
        if compliance_m_per_n is not None:
            from dataclasses import replace

            replayer.pad = replace(replayer.pad, compliance_m_per_n=compliance_m_per_n)
            replayer.pipeline.pad = replayer.pad
        if replay != "recorded":
            current = replay == "current"
            replayer.legacy_contacts = not current
            replayer.pipeline = ContactPipeline(replayer.kinematics, replayer.pad, replayer.settling,
                                                centre_of_pressure=current,
                                                doubt=LoopConfig().doubt_rule() if current else DoubtRule(-np.inf))
        touches = replayer.run(_settings())
        rows = [dict(index=t.index, kind=t.kind, strategy=t.strategy, position_m=t.position_m, normal=t.normal,
                     quality=_quality_dict(t.quality), target_m=t.target_m, approach_dir=t.approach_dir)
                for t in touches.touches if t.position_m is not None]
    else:
        rows = []
        for event in SessionReader(session).events():
            fields = event.fields
            if fields.get("position_m") is None or "result" not in fields:
                continue
            rows.append(dict(index=fields.get("index"), kind=fields["result"], strategy=fields.get("strategy", ""),
                             position_m=np.asarray(fields["position_m"], float),
                             normal=np.asarray(fields["normal"], float), quality=fields.get("quality") or {},
                             target_m=_vector(fields.get("target_m")), approach_dir=_vector(fields.get("approach_dir"))))
    press_force_n = ((metadata.get("configuration") or {}).get("loop") or {}).get("press_force_n")
    for row in rows:
        row["press_force_n"] = press_force_n
    return str(metadata.get("object")), rows


def _vector(value):
    return None if value is None else np.asarray(value, float)


def _settings():
    from explorer.replay import ReplaySettings

    return ReplaySettings(figures=False)


def _quality_dict(quality) -> dict:
    if quality is None:
        return {}
    from dataclasses import asdict

    return {k: v for k, v in asdict(quality).items() if v is not None}


def analyse(object_name: str, rows: list[dict], run: Path | None = None):
    """Per-contact table (list of dicts) with the truth errors and local shape added."""
    from explorer.contact_truth import contact_truth
    from scripts._cli import recorded_object

    if not rows:
        return []
    model = recorded_object("contact_quality", run, object_name)
    truth = contact_truth(np.array([r["position_m"] for r in rows]), np.array([r["normal"] for r in rows]),
                          model.mesh, model.sharp_edges)
    out = []
    for i, row in enumerate(rows):
        q = row["quality"]
        out.append(dict(object=object_name, index=row["index"], kind=row["kind"], strategy=row["strategy"],
                        position_error_mm=1e3 * truth.position_error_m[i], offset_mm=1e3 * truth.offset_m[i],
                        normal_error_deg=float(np.degrees(truth.normal_error_rad[i])),
                        edge_distance_mm=1e3 * truth.edge_distance_m[i],
                        normal_spread_deg=float(np.degrees(truth.normal_spread_rad[i])),
                        doubtful=bool(q.get("doubtful", False)),
                        tilt_deg=_deg(q.get("tilt_rad")), rim_distance_mm=_mm(q.get("rim_distance_m")),
                        approach_deg=_deg(None if q.get("approach_cosine") is None
                                          else float(np.arccos(np.clip(q["approach_cosine"], -1, 1)))),
                        force_n=q.get("force_n"), past_target_mm=_past_target_mm(row),
                        incidence_deg=_incidence_deg(row, truth.true_normal[i]),
                        force_ratio=_force_ratio(q, row.get("press_force_n"))))
    return out


def _past_target_mm(row) -> float:
    """How far along its approach the contact lies past the touch's target, mm (NaN if unknown)."""
    if row.get("target_m") is None or row.get("approach_dir") is None:
        return float("nan")
    return 1e3 * float(np.dot(np.asarray(row["position_m"]) - row["target_m"], row["approach_dir"]))


def _incidence_deg(row, true_normal: np.ndarray) -> float:
    """Angle between the approach and the true inward normal, deg (NaN if unknown)."""
    if row.get("approach_dir") is None:
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(-np.dot(row["approach_dir"], true_normal), -1.0, 1.0))))


def _force_ratio(quality: dict, press_force_n) -> float:
    """The press's peak force (the settled force where no peak was recorded) over the loop's press force."""
    force = quality.get("peak_force_n")
    if force is None:
        force = quality.get("force_n")
    if force is None or not press_force_n:
        return float("nan")
    return float(force) / float(press_force_n)


def _deg(value):
    return None if value is None else float(np.degrees(value))


def _mm(value):
    return None if value is None else 1e3 * float(value)


def summary(table: list[dict]) -> dict:
    """Errors of the contacts used, the set-aside ones, and per bin."""
    used = [r for r in table if r["kind"] == "contact"]
    out = dict(contacts=len(used), realign=sum(r["kind"] == "realign" for r in table))
    if used:
        pos = np.array([r["position_error_mm"] for r in used])
        ang = np.array([r["normal_error_deg"] for r in used])
        doubtful = np.array([r["doubtful"] for r in used])
        out.update(position_rms_mm=float(np.sqrt(np.mean(pos ** 2))), normal_mean_deg=float(ang.mean()),
                   doubtful_fraction=float(doubtful.mean()),
                   offset_median_mm=float(np.median([r["offset_mm"] for r in used])))
        forced = [r for r in used if r["force_n"] is not None]
        if len({r["force_n"] for r in forced}) > 1:
            out["offset_slope_mm_per_n"] = float(np.polyfit([r["force_n"] for r in forced],
                                                            [r["offset_mm"] for r in forced], 1)[0])
        for name, mask in (("trusted", ~doubtful), ("doubtful", doubtful)):
            if mask.any():
                out[f"{name}_position_rms_mm"] = float(np.sqrt(np.mean(pos[mask] ** 2)))
                out[f"{name}_normal_mean_deg"] = float(ang[mask].mean())
    return out


def binned(table: list[dict], key: str, edges) -> list[dict]:
    """Rows per bin ``[lo, hi)`` of ``key`` over the contacts used (NaN values in no bin): ``n``,
    position RMS, normal mean, doubtful fraction and ``error_share``, the bin's share of all used
    contacts' squared position error."""
    used = [r for r in table if r["kind"] == "contact"]
    total = float(sum(r["position_error_mm"] ** 2 for r in used))
    rows = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        inside = [r for r in used if lo <= r[key] < hi]
        label = f"< {hi:g}" if not np.isfinite(lo) else f"{lo:g}-{hi:g}" if np.isfinite(hi) else f">= {lo:g}"
        row = dict(bin=label, n=len(inside))
        if inside:
            squared = [r["position_error_mm"] ** 2 for r in inside]
            row.update(position_rms_mm=float(np.sqrt(np.mean(squared))),
                       normal_mean_deg=float(np.mean([r["normal_error_deg"] for r in inside])),
                       doubtful=float(np.mean([r["doubtful"] for r in inside])),
                       error_share=float(sum(squared) / total) if total > 0 else 0.0)
        rows.append(row)
    return rows


def _print_bins(title: str, rows: list[dict]) -> None:
    print(f"\n{title}\n| bin | contacts | position RMS mm | normal mean deg | doubtful | share of squared position error |"
          "\n|---|---|---|---|---|---|")
    for r in rows:
        if r["n"]:
            print(f"| {r['bin']} | {r['n']} | {r['position_rms_mm']:.2f} | {r['normal_mean_deg']:.1f} | "
                  f"{r['doubtful']:.2f} | {r['error_share']:.2f} |")
        else:
            print(f"| {r['bin']} | 0 | | | | |")


def main(argv=None) -> int:
    args = parse_args(argv)
    table = []
    per_run = {}
    print("| run | object | contacts | realign | position RMS mm | normal mean deg | doubtful | "
          "trusted: pos / normal | doubtful: pos / normal |\n|---|---|---|---|---|---|---|---|---|")
    for run in args.runs:
        name, rows = run_contacts(run, args.replay, None if args.compliance is None else 1e-3 * args.compliance)
        rows_table = analyse(name, rows, run)
        table += rows_table
        s = summary(rows_table)
        per_run[str(run)] = dict(object=name, **s)
        if not s.get("contacts"):
            print(f"| {run.name} | {name} | 0 | {s['realign']} | | | | | |")
            continue
        split = [f"{s[f'{k}_position_rms_mm']:.2f} / {s[f'{k}_normal_mean_deg']:.1f}"
                 if f"{k}_position_rms_mm" in s else "-" for k in ("trusted", "doubtful")]
        print(f"| {run.name} | {name} | {s['contacts']} | {s['realign']} | {s['position_rms_mm']:.2f} | "
              f"{s['normal_mean_deg']:.1f} | {s['doubtful_fraction']:.2f} | {split[0]} | {split[1]} |")
    total = summary(table)
    if total.get("contacts"):
        print(f"\nall: {total['contacts']} contacts, {total['realign']} realign, position RMS "
              f"{total['position_rms_mm']:.2f} mm, normal mean {total['normal_mean_deg']:.1f} deg, "
              f"doubtful {total['doubtful_fraction']:.2f}; offset from the surface median "
              f"{total['offset_median_mm']:+.2f} mm, slope {total.get('offset_slope_mm_per_n', float('nan')):+.2f} mm/N")
    edge = binned(table, "edge_distance_mm", (0, 3, 6, 9, 15, np.inf))
    spread = binned(table, "normal_spread_deg", (0, 10, 25, 45, 70, 181))
    past = binned(table, "past_target_mm", (-np.inf, 9, 20, 40, 80, np.inf))
    incidence = binned(table, "incidence_deg", (0, 15, 30, 45, 60, 181))
    force = binned(table, "force_ratio", (0, 0.5, 0.98, 2, 4, np.inf))
    _print_bins("by distance of the true closest point to a sharp edge (mm)", edge)
    _print_bins("by turn of the true normal within 9 mm (deg)", spread)
    _print_bins("by distance past the touch's target along its approach (mm; 9 = half the pad)", past)
    _print_bins("by angle between the approach and the true normal (deg)", incidence)
    _print_bins("by the press's peak force over the loop's press force", force)
    if args.csv:
        import csv

        with open(args.csv, "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(table[0]) if table else ["object"])
            writer.writeheader()
            writer.writerows(table)
    if args.json:
        args.json.write_text(json.dumps(dict(runs=per_run, all=total, by_edge_distance_mm=edge,
                                             by_normal_spread_deg=spread, by_past_target_mm=past,
                                             by_incidence_deg=incidence, by_force_ratio=force), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
