"""The per-split reading of a sweep over generated objects (explorer/sweep/splits.py, scripts/split_report.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from explorer.sweep.results import COLUMNS, write_csv
from explorer.sweep.splits import family_table, object_results, split_of, target_summary
from scripts.split_report import main as split_report_main


def _row(obj, seed, rmse, coverage=0.7, strategy="variance", completed=True):
    row = {key: None for key in COLUMNS}
    row.update(object=obj, strategy=strategy, normals=True, seed=seed, touches=100, contacts=60,
               position_rmse_mm=rmse, coverage=coverage, completed=completed, error=None if completed else "boom",
               run=f"{obj.replace(':', '_').replace('/', '_')}-{strategy}-seed{seed}",
               touches_to_3mm=40 if rmse <= 3 else None)
    return row


ROWS = [_row("generated:mug/1000", 1, 1.0), _row("generated-mug-1000", 2, 3.0),      # mean 2.0 (a sweep's label)
        _row("generated:wedge/1000", 1, 4.0, coverage=0.9),                           # over 3 mm
        _row("generated:bowl/1000", 1, 1.5), _row("generated:bowl/1000", 2, 9.9, completed=False),
        _row("generated:mug/0", 1, 0.5), _row("box", 1, 7.0)]


def test_objects_are_averaged_over_finished_seeds_and_split_by_the_fixed_lists():
    results = {r.name: r for r in object_results(ROWS)}
    assert set(results) == {"generated:mug/1000", "generated:wedge/1000", "generated:bowl/1000", "generated:mug/0"}
    assert results["generated:mug/1000"].rmse_mm == pytest.approx(2.0)
    assert results["generated:mug/1000"].rmse_mm_spread == (1.0, 3.0)
    assert results["generated:bowl/1000"].seeds == 1  # the failed seed is not averaged in
    assert results["generated:mug/0"].split == "tuning" and split_of("generated:mug/1000") == "held-out"
    assert split_of("box") is None


def test_the_summary_counts_objects_against_the_targets():
    text = target_summary(object_results(ROWS))
    held_out = next(line for line in text.split("\n\n") if line.startswith("held-out"))
    assert f"RMSE median {np.median([2.0, 4.0, 1.5]):.2f} mm" in held_out
    assert "over 3 mm: 1/3 (wedge/1000 4.00)" in held_out
    assert "objects >= 0.8: 1/3" in held_out
    assert "extra handles" not in held_out  # rows from before the column: nothing claimed
    holed = [dict(r, extra_handles=(3.0 if "bowl" in r["object"] else 0.0)) for r in ROWS]
    held_out = next(line for line in target_summary(object_results(holed)).split("\n\n")
                    if line.startswith("held-out"))
    assert held_out.endswith("; extra handles: 1/3 (bowl/1000 3.0)")
    # mug, mug, wedge, bowl: the wedge's 5 % recess is too small to count
    figures = ((0.5, 4.0, 1.0), (0.5, 6.0, 1.0), (0.05, 9.0, 2.0), (0.5, 3.0, 1.5))
    recessed = [dict(r, recess_fraction=share, recess_rmse_mm=inside, open_rmse_mm=outside)
                for r, (share, inside, outside) in zip(ROWS, figures)]
    held_out = next(p for p in target_summary(object_results(recessed + ROWS[4:])).split("\n\n")
                    if p.startswith("held-out"))
    assert held_out.endswith("; the 2 objects with recesses (>= 10% of the area): truth -> reconstruction RMS "
                             "4.00 mm in them, 1.25 mm elsewhere (means)")
    table = family_table(object_results(ROWS))
    assert "| mug | 0.50 |" in table and "mug/1000 2.00 (1.00-3.00)" in table


def test_several_strategies_must_be_named():
    rows = ROWS + [_row("generated:mug/1000", 1, 1.2, strategy="efficient")]
    with pytest.raises(ValueError, match="several strategies"):
        object_results(rows)
    assert {r.name for r in object_results(rows, "efficient")} == {"generated:mug/1000"}


def test_the_command_writes_the_report_and_the_figure(tmp_path, capsys):
    write_csv(ROWS, tmp_path / "sweep.csv")
    for row in ROWS:
        if row["completed"]:
            run = tmp_path / "runs" / row["run"]
            run.mkdir(parents=True)
            curve = [dict(touches=n, position_rmse_mm=row["position_rmse_mm"] * 100 / n) for n in (20, 60, 100)]
            (run / "metrics.json").write_text(json.dumps(dict(error_curve=curve)))
    assert split_report_main([str(tmp_path)]) == 0
    assert (tmp_path / "split_error.png").stat().st_size > 0
    assert "over 3 mm: 1/3" in (tmp_path / "split_report.md").read_text()
    with pytest.raises(SystemExit) as exit_:
        split_report_main([str(tmp_path / "missing")])
    assert exit_.value.code == 2 and "sweep.csv not found" in capsys.readouterr().err
