"""Excitation design: the followed path keeps the limits, the optimiser beats random
multisines of the same limits, parameters it cannot design for are refused; and ``drs excite``
writes a goal and a bag whose run fits tighter than the seed's manoeuvre over the same time."""

from __future__ import annotations

import json

import numpy as np
import pytest

from drs_model.cli import main as drs_main
from drs_model.errors import InputError
from drs_model.fidelity import HydraulicParams
from drs_model.identify.excitation import (
    Waveform,
    _amplitude,
    _FollowedPath,
    default_limits,
    design_excitation,
    path_samples,
)
from drs_model.identify.information import (
    information,
    rung_motion,
    seed_manoeuvre_information,
    standard_errors,
)
from drs_model.inverse import FusedInverseDynamics
from drs_model.kinematics import stroke_limits

NAMES = ("m_pist", "Iz_wing", "F_drag_open", "F_down_closed")


@pytest.fixture(scope="module")
def design(params):
    return design_excitation(
        NAMES, params, HydraulicParams(), rung="hydraulic", seed=1, starts=2, maxiter=150
    )


def test_the_followed_path_keeps_the_limits(design, params):
    lim = default_limits(params, HydraulicParams())
    s_min, s_max = stroke_limits(params)
    assert design.s[0] == s_min and design.sd[0] == 0.0  # from rest at the closed stop
    assert s_min <= design.s.min() and design.s.max() <= s_max - lim.margin
    assert np.abs(design.sd).max() <= lim.rate
    assert np.abs(design.force).max() <= lim.force
    assert design.rates[-1] == 0.0 and abs(design.sd[-1]) < 1e-9  # ends at rest
    # the path is the one the node follows: the same points give the same samples
    s, sd, sdd = path_samples(params, design.times, design.strokes, design.rates, design.t)
    assert np.array_equal(s, design.s) and np.array_equal(sdd, design.sdd)


def test_the_design_beats_random_multisines_within_the_same_limits(design, params):
    """Each judged on the path the actuator follows through its points, at the largest amplitude
    that path keeps the limits at: the design's worst ratio to the seed's manoeuvre is below
    that of 20 random multisines of as many harmonics."""
    hp = HydraulicParams()
    lim = default_limits(params, hp)
    wave = Waveform(0.3, stroke_limits(params)[0] + lim.margin, 10)
    t = np.arange(0.0, 0.3005, 1e-3)
    local = np.arange(0.0, 0.3 + 1e-3, 2e-3)
    force = FusedInverseDynamics.from_params(params).force_array
    followed = _FollowedPath(params, wave, local, design.t, lim, force)
    seed = standard_errors(
        seed_manoeuvre_information(NAMES, params, hp, "hydraulic", float(design.t[-1])),
        NAMES,
        params,
        hp,
    )
    rng = np.random.default_rng(11)
    best_random = np.inf
    for _ in range(20):
        c = rng.normal(size=20)
        _, path = followed.at_limits(c, _amplitude(wave, c, t, lim, force, stroke_limits(params)))
        if path is not None:
            std = standard_errors(
                information(NAMES, *path, params, hp, "hydraulic"), NAMES, params, hp
            )
            best_random = min(best_random, float(np.max(std / seed)))
    assert np.max(design.std / seed) < best_random


def test_a_parameter_the_motion_alone_does_not_inform_is_refused(params):
    with pytest.raises(InputError, match="leak_to_outside depend on the pressures"):
        design_excitation(["m_pist", "leak_to_outside"], params)
    with pytest.raises(InputError, match="'rigid' rung has no friction"):
        design_excitation(["viscous_friction"], params, rung="rigid")


def test_drs_excite_writes_a_goal_whose_bag_and_run_fit_tighter(tmp_path, params, capsys):
    """``drs excite -o`` writes the goal, ``drs-bag from-goal`` the bag of it (its trajectory
    command, the goal's points to the bit); a run of that trajectory on the hydraulic rung
    (recorded as the node records it) fits every parameter more tightly than a run of the
    seed's manoeuvre of the same length, with the same stroke noise."""
    import yaml
    from ros_support import require_rclpy

    require_rclpy()
    from decoded_support import read_bag
    from run_support import Command, record_run, seed_commands

    from drs_ros.bag.cli import main as bag_main

    goal, bag = tmp_path / "goal.yaml", tmp_path / "excite"
    assert (
        drs_main(
            ["excite", ",".join(NAMES), "--seed", "1", "--starts", "2", "-o", str(goal), "--json"]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    assert bag_main(["from-goal", str(goal), "-o", str(bag)]) == 0
    assert "on /drs/trajectory_cmd" in capsys.readouterr().out
    trajectory = yaml.safe_load(goal.read_text())["trajectory"]
    (msg,) = [m for _, m in read_bag(bag, ["/drs/trajectory_cmd"]).messages["/drs/trajectory_cmd"]]
    assert list(msg.joint_names) == trajectory["joint_names"] == ["drs_piston"]
    assert [
        (list(p.positions), list(p.velocities), p.time_from_start.sec, p.time_from_start.nanosec)
        for p in msg.points
    ] == [
        (
            p["positions"],
            p["velocities"],
            p["time_from_start"]["sec"],
            p["time_from_start"]["nanosec"],
        )
        for p in trajectory["points"]
    ]
    steps = int(round(report["duration_s"] * 1000))
    noise = {"sensor.noise_std_m": 1e-5, "sensor.noise_seed": 2}
    runs = {
        "excitation": record_run(
            tmp_path / "ex",
            steps,
            [Command(1, "trajectory_cmd", trajectory)],
            fidelity="hydraulic",
            faults=noise,
        ),
        "seed": record_run(
            tmp_path / "seed", steps, seed_commands(params), fidelity="hydraulic", faults=noise
        ),
    }
    widths = {}
    for label, run in runs.items():
        assert (
            bag_main(
                ["fit", str(run), "--params", ",".join(NAMES), "--stage", "equation", "--json"]
            )
            == 0
        )
        doc = json.loads(capsys.readouterr().out)
        widths[label] = {e["name"]: e["upper"] - e["lower"] for e in doc["estimates"]}
    for name in NAMES:
        assert widths["excitation"][name] < widths["seed"][name], (name, widths)


def test_no_parameter_asked_for_ends_looser_than_under_the_seeds_manoeuvre(params):
    """``drs excite m_pist,Iz_wing,F_drag_open,F_down_closed --fidelity rigid``'s design, run on
    the rigid rung: the standard errors it predicts and those the project's equation-error fit
    gives (the mean over ten stroke-noise draws of 10 um) are each below the seed's manoeuvre's
    over the same time, and the prediction is within 25 % of the fit."""
    from identify_support import noisy_record, run_rung

    from drs_model.identify.equation_error import rigid_stage

    hp = HydraulicParams()
    ex = design_excitation(NAMES, params, hp, rung="rigid", point_spacing=4e-3)
    length = float(ex.t[-1])
    steps = int(round(length / 1e-3))
    ran = rung_motion(params, hp, "rigid", length, 1e-3, (ex.times, ex.strokes, ex.rates))
    predicted = standard_errors(information(NAMES, *ran, params, hp, "rigid"), NAMES, params, hp)
    predicted_seed = standard_errors(
        seed_manoeuvre_information(NAMES, params, hp, "rigid", length), NAMES, params, hp
    )
    close = int(round((params.T_opening + params.T_still) / 1e-3))
    tables = {
        "excitation": run_rung(
            "rigid", params, steps=steps, trajectory=(ex.times, ex.strokes, ex.rates)
        ),
        "seed": run_rung("rigid", params, moves=((0, True), (close, False)), steps=steps),
    }
    fitted = {
        label: np.mean(
            [
                [
                    e.std
                    for e in rigid_stage(
                        noisy_record(table, 1e-5, k), NAMES, "rigid", params, 0.95
                    ).estimates
                ]
                for k in range(10)
            ],
            axis=0,
        )
        for label, table in tables.items()
    }
    assert np.all(predicted < predicted_seed), (predicted, predicted_seed)
    assert np.all(fitted["excitation"] < fitted["seed"]), fitted
    assert np.allclose(predicted, fitted["excitation"], rtol=0.25)
    assert np.allclose(predicted_seed, fitted["seed"], rtol=0.25)
