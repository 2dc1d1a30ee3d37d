"""The PPO recipe (examples/train_ppo.py) runs end to end and saves what evaluation loads."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "examples" / "train_ppo.py"


def test_recipe_trains_saves_and_its_model_evaluates(tmp_path):
    pytest.importorskip("stable_baselines3")
    if not SCRIPT.is_file():
        pytest.skip("examples/ not shipped with this installation")
    out = tmp_path / "ppo"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    # three rollouts of 8 sub-environments x 16 steps
    subprocess.run([sys.executable, str(SCRIPT), "--out", str(out), "--envs", "8",
                    "--steps", "384", "--ppo-kwargs",
                    json.dumps({"n_steps": 16, "batch_size": 64, "n_epochs": 1})],
                   check=True, env=env, timeout=600)
    for name in ("model.zip", "model.vecnormalize.pkl", "model.vfs.json",
                 "learning_curve.csv", "learning_curve.png"):
        assert (out / name).is_file(), name
    settings = json.loads((out / "model.vfs.json").read_text())
    # the recipe's environment settings travel with the model; the case selection does not
    assert settings["env_kwargs"]["threat_features"] is True
    assert settings["env_kwargs"]["action_repeat"] == 10
    assert "split" not in settings["env_kwargs"] and "db" not in settings["env_kwargs"]
    curve = pd.read_csv(out / "learning_curve.csv")
    assert len(curve) == 3 and (curve["steps"].diff().dropna() > 0).all()

    from vfs.gym.evaluate import evaluate_policy, leaderboard

    ev = tmp_path / "eval"
    result = evaluate_policy([f"sb3:{out / 'model'}", "never-brake"], "default", str(ev),
                             split="all", where="case_id <= 30", engine="serial",
                             n_boot=50)
    assert result.complete
    board = leaderboard(ev)
    assert list(board["policy"]) == ["sb3:model", "never-brake"]
    never = board.set_index("policy").loc["never-brake"]
    assert never["avoided"] == 0.0 and never["near_miss_brakes"] == 0
