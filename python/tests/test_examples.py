"""examples/: the registry script reads what bidex's registry holds."""
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BINARY = os.environ.get("BIDEX_BINARY", "")


def test_registry_scores_lists_tasks_by_age_and_normalises_run_scores(tmp_path):
    if not BINARY:
        pytest.skip("BIDEX_BINARY not set")
    reg = tmp_path / "r.sqlite"
    listed = subprocess.run([BINARY, "registry", "list", "--by", "age", "--registry", str(reg)],
                            check=True, capture_output=True, text=True).stdout
    lines = listed.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["id", "age"])
    ids = [line.split()[0] for line in lines[head + 1:] if line.strip()]
    assert len(ids) == 20
    # a finished run with one score half way between hand_over's references
    db = sqlite3.connect(reg)
    r, g = (db.execute("SELECT value FROM reference_scores WHERE task='hand_over' AND kind=?",
                       (k,)).fetchone()[0] for k in ("random", "ground_truth"))
    db.execute("INSERT INTO runs (algo, task, seed, started, status) VALUES "
               "('ppo', 'hand_over', 0, '2026-11-27', 'finished')")
    run = db.execute("SELECT max(id) FROM runs").fetchone()[0]
    db.execute("INSERT INTO run_scores (run, label, task, mean_return, success, position) "
               "VALUES (?, 'hand_over', 'hand_over', ?, 0.5, 0)", (run, (r + g) / 2))
    db.commit()
    db.close()
    out = subprocess.run([sys.executable, str(ROOT / "examples" / "registry_scores.py"),
                          str(reg)], check=True, capture_output=True, text=True).stdout
    lines = out.splitlines()
    rows = lines[1:1 + len(ids)]
    assert [line.split()[0] for line in rows] == ids  # the same age order as bidex's own
    assert any(line.split()[0] == "hand_over" and line.split()[-1] == f"{g:.4g}" for line in rows)
    assert "1 scores of finished runs" in out
    assert "normalised 0.500" in lines[-1] and "success 0.50" in lines[-1]
    bad = subprocess.run([sys.executable, str(ROOT / "examples" / "registry_scores.py"),
                          str(tmp_path / "none.sqlite")], capture_output=True, text=True)
    assert bad.returncode != 0 and "no registry file there" in bad.stderr
