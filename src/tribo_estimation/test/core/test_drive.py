"""The drive profile: the speed channel's smoothed profile and its refit to drive angles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tribo_estimation.core.drive import (
    COSINE,
    DriveEstimate,
    estimate_drive,
    refine_with_angles,
    untimed_transitions,
    with_durations,
)

FS = 1000.0


def _stop_and_restart(t: np.ndarray) -> np.ndarray:
    """5 rad/s, down to rest at 3.0-3.5 s, at rest to 4.8 s, back up at 4.8-5.3 s [rad/s]."""
    return np.interp(t, [0.0, 3.0, 3.5, 4.8, 5.3, 8.0], [5.0, 5.0, 0.0, 0.0, 5.0, 5.0])


def test_refine_keeps_the_speed_channel_where_no_angles_pin_the_profile() -> None:
    # angles only through the stop (a long stick) and a few near the end: stick phases
    # too short to sample elsewhere (a low sample rate)
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 8.0, 1.0 / FS)
    speed = _stop_and_restart(t) + rng.normal(0.0, 0.02, t.size)
    drive = estimate_drive(t, speed)
    ta = np.concatenate((np.arange(3.6, 4.7, 0.002), np.arange(7.0, 7.2, 0.05)))
    fine = np.arange(0.0, 8.0, 1e-4)
    angle = np.interp(ta, fine, np.cumsum(_stop_and_restart(fine)) * 1e-4)
    phi = 0.3 + angle + rng.normal(0.0, 1e-4, ta.size)
    got = refine_with_angles(drive, ta, phi)
    # where no angle pins it the profile keeps the channel's 5 rad/s (its noise
    # averaged: 0.02 rad/s is 4x the smoothed level's); the stop stays at rest
    for when in (0.5, 1.5, 2.5, 6.0, 7.5):
        assert float(got.speed(when)) == pytest.approx(5.0, abs=0.05), when
    assert float(got.speed(4.0)) == pytest.approx(0.0, abs=0.01)


@pytest.mark.parametrize('cosine', [(), (1, 4)])
def test_angle_basis_integrates_the_hat_functions(cosine: tuple[int, ...]) -> None:
    # the integral from the first knot of each basis function (hat, or raised cosine on
    # the pieces ``cosine``), against a trapezoid sum on a 1 us grid (tolerance 1e-9 s:
    # the sum's error on a piecewise smooth integrand); samples before the first knot,
    # on the knots and past the last
    from tribo_estimation.core.drive import COSINE, _angle_basis

    rng = np.random.default_rng(5)
    tk = np.sort(rng.uniform(0.0, 0.2, 7))
    tt = np.concatenate((rng.uniform(tk[0] - 0.01, 0.25, 50), tk))
    sk = np.zeros(tk.size)
    sk[list(cosine)] = COSINE
    grid = np.arange(tk[0], 0.25 + 1e-6, 1e-6)
    got = _angle_basis(tk, tt, sk)
    for j in range(tk.size):
        unit = np.zeros(tk.size)
        unit[j] = 1.0
        hat = np.interp(grid, tk, unit)  # held at the last knot's value beyond it
        for p in cosine:
            inside = (grid > tk[p]) & (grid < tk[p + 1])
            f = (grid[inside] - tk[p]) / (tk[p + 1] - tk[p])
            rise = 0.5 - 0.5 * np.cos(np.pi * f)
            hat[inside] = unit[p] + (unit[p + 1] - unit[p]) * rise
        cum = np.concatenate(([0.0], np.cumsum(0.5 * (hat[1:] + hat[:-1]) * np.diff(grid))))
        want = np.where(tt < tk[0], 0.0, np.interp(tt, grid, cum))
        assert got[:, j] == pytest.approx(want, abs=1e-9), j


def test_knot_normal_equations_match_an_orthogonal_solve_of_the_stacked_rows() -> None:
    # the Gram matrix of the angle rows plus the penalty and pull terms gives lstsq's
    # solution of the stacked rows (angles, second differences, pull toward a prior;
    # a known first speed moved to the right-hand side) to a relative 1e-8, the last
    # knot with no angle near it held by the pull alone; the sparse assembly
    # (per-piece sums) against the dense rows, also for unsorted angles past the last
    # knot and a raised-cosine piece
    from tribo_estimation.core.drive import (
        _KNOT_SMOOTH,
        COSINE,
        _angle_basis,
        _pull_weights,
        _solve_speeds,
    )

    rng = np.random.default_rng(6)
    tk = np.array([0.0, 0.2, 0.35, 0.6, 0.8, 1.0])
    tt = np.sort(rng.uniform(0.0, 0.7, 500))
    ph = 0.1 + 2.0 * tt + 0.3 * np.sin(3.0 * tt) + rng.normal(0.0, 1e-3, tt.size)
    prior = (np.array([0.0, 1.0]), np.array([2.0, 3.0]))
    k = tk.size
    # unsorted angles, some past the last knot, and a raised-cosine piece
    wide = rng.uniform(0.0, 1.2, 300)
    wide_ph = 0.1 + 2.0 * wide + rng.normal(0.0, 1e-3, wide.size)
    sk = np.array([0.0, 0.0, COSINE, 0.0, 0.0, 0.0])
    cases = [(tt, ph, None, None), (tt, ph, 2.1, None), (wide, wide_ph, None, sk)]
    for tt, ph, start, sk in cases:
        vk, sse = _solve_speeds(tk, tt, ph, start, prior, sk=sk)
        d2 = np.zeros((k - 2, k + 1))
        for i in range(k - 2):
            d2[i, 1 + i : 4 + i] = _KNOT_SMOOTH * np.array([1.0, -2.0, 1.0])
        w = _pull_weights(tk, np.sort(tt))
        if start is not None:
            w[0] = 0.0
        pull = np.column_stack((np.zeros(k), np.diag(w)))
        rows = np.vstack((np.column_stack((np.ones(tt.size), _angle_basis(tk, tt, sk))), d2, pull))
        rhs = np.concatenate((ph, np.zeros(k - 2), w * np.interp(tk, *prior)))
        if start is not None:
            rhs = rhs - start * rows[:, 1]
            rows = np.delete(rows, 1, axis=1)
        x = np.linalg.lstsq(rows, rhs, rcond=None)[0]
        ref = x[1:] if start is None else np.concatenate(([start], x[1:]))
        assert vk == pytest.approx(ref, rel=1e-8, abs=1e-10)
        r = rows[: tt.size] @ x - rhs[: tt.size]
        assert sse == pytest.approx(float(r @ r), rel=1e-6)


def test_a_singular_knot_system_gets_the_least_squares_residual() -> None:
    # two equal columns: the Gram matrix is not positive definite; the solve falls back
    # to the least-norm solution, whose residual is lstsq's (relative 1e-9)
    from tribo_estimation.core.drive import _solve_normal

    rng = np.random.default_rng(6)
    a = np.column_stack((np.ones(3000), rng.uniform(0.0, 8.0, (3000, 12))))
    b = a @ rng.normal(size=13) + rng.normal(0.0, 1e-3, 3000)
    ref = np.linalg.lstsq(a, b, rcond=None)[0]
    twin = np.column_stack((a, a[:, 1]))
    x = _solve_normal(twin.T @ twin, twin.T @ b)
    assert float(np.sum((twin @ x - b) ** 2)) == pytest.approx(
        float(np.sum((a @ ref - b) ** 2)), rel=1e-9
    )


def test_a_known_start_speed_enters_the_knot_penalty() -> None:
    # a drive at 2 rad/s + 0.5 rad/s^2, its first knot's speed known: noise-free angles
    # give the knot speeds to 1e-10 rad/s (the second-difference penalty is zero at
    # the truth only when it sees the known 2 rad/s, not 0)
    from tribo_estimation.core.drive import _solve_speeds

    tk = np.linspace(0.0, 1.0, 6)
    tt = np.sort(np.random.default_rng(1).uniform(0.0, 1.0, 40))
    vk, sse = _solve_speeds(tk, tt, 0.3 + 2.0 * tt + 0.25 * tt * tt, start=2.0)
    assert vk == pytest.approx(2.0 + 0.5 * tk, abs=1e-10)
    assert sse < 1e-20


def _stepped(knots: list[float]) -> DriveEstimate:
    """A profile at 2 rad/s with knots ``knots`` stepping to 1 rad/s over knots 1-2."""
    tk = np.asarray(knots)
    vk = np.where(np.arange(tk.size) <= 1, 2.0, 1.0)
    return DriveEstimate(tk, vk, float('nan'), 1.5, float('nan'))


def test_a_step_is_untimed_unless_angles_spread_between_its_corners() -> None:
    drive = _stepped([0.0, 1.0, 1.03, 1.5, 3.0])
    stick = np.concatenate((np.arange(0.2, 0.99, 0.002), np.arange(1.04, 1.45, 0.002)))
    # angles only on the plateaus: the pair 1.0-1.03 s is open (the pair 1.03-1.5 s is
    # no transition: 0.47 s apart)
    assert untimed_transitions(drive, stick) == [1]
    # angles through the step (a stick phase inside it) time it
    inside = np.concatenate((stick, np.arange(1.002, 1.029, 0.002)))
    assert untimed_transitions(drive, inside) == []
    # a stick phase's end taken in by an early corner (angles over 4 of its 30 ms) does not
    edge = np.concatenate((stick, np.arange(1.002, 1.006, 0.001)))
    assert untimed_transitions(drive, edge) == [1]


def test_durations_keep_each_transitions_mid_time_within_its_neighbours() -> None:
    drive = _stepped([0.0, 1.0, 1.03, 1.5, 3.0])
    # 15 ms at the pair's own mid-time (1.015 s), the speeds kept (to 1e-12 s and rad/s)
    d = with_durations(drive, ((1.02, 0.015),))
    assert d.knot_time == pytest.approx([0.0, 1.0075, 1.0225, 1.5, 3.0], abs=1e-12)
    assert np.array_equal(d.knot_speed, drive.knot_speed)
    # longer than the room about its mid-time: held 2 ms (the shortest piece) short of
    # the nearer neighbour (1.5 s), as far on the other side
    wide = with_durations(drive, ((1.015, 2.0),))
    assert wide.knot_time[1] == pytest.approx(0.532, abs=1e-12)
    assert wide.knot_time[2] == pytest.approx(1.498, abs=1e-12)
    # no pair near the given mid-time: the profile itself
    assert with_durations(drive, ((2.5, 0.01),)) is drive


def _slow_stick_slip(t: np.ndarray, drive: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Shaft speed of stick-slip whose cycle (190-230 ms) is longer than the smoothing.

    Each cycle slips in a half-sine burst over 30 % of its length and then sticks at
    rest until the drive has wound the belt back up: the angle slipped is the drive's
    over the cycle (its mean speed is the drive's); white noise 0.01 rad/s [rad/s].
    """
    w = np.zeros_like(t)
    t0 = 0.0
    while t0 < t[-1]:
        period = rng.uniform(0.19, 0.23)
        i = (t >= t0) & (t < t0 + period)
        v = float(np.mean(drive[i])) if i.any() else 0.0
        s = (t[i] - t0) / (0.3 * period)
        w[i] = np.where(s < 1.0, 0.5 * np.pi * v / 0.3 * np.sin(np.pi * np.clip(s, 0, 1)), 0.0)
        t0 += period
    return w + rng.normal(0.0, 0.01, t.size)


def test_slow_stick_slip_cycles_leave_no_ripple_in_the_profile() -> None:
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 6.0, 1.0 / FS)
    drive = np.where(t < 3.0, 1.0, 0.5)
    est = estimate_drive(t, _slow_stick_slip(t, drive, rng), 1.0)
    # the step is one transition, not a chain of knots following the cycles
    assert est.knot_time.size <= 6
    # away from the step (+-0.4 s, two cycles), within 3 % of the drive speed:
    # the cycles' means scatter by the random cycle lengths (the last cycle is partial)
    away = (np.abs(t - 3.0) > 0.4) & (t > 0.4) & (t < 5.6)
    assert np.max(np.abs(est.speed(t[away]) / drive[away] - 1.0)) < 0.03


def test_a_knot_the_angles_barely_reach_keeps_the_channels_speed() -> None:
    # 5 rad/s sliding to 0.6 s (no angles), a step to 3 rad/s at 0.6-0.7 s, angles from
    # 0.68 s on: the first knot's support holds 20 ms of angles, too little to pin it
    t = np.arange(0.0, 3.0, 1.0 / FS)
    speed = np.interp(t, [0.0, 0.6, 0.7, 3.0], [5.0, 5.0, 3.0, 3.0])
    drive = estimate_drive(t, speed)
    tt = np.arange(0.68, 3.0, 0.002)
    phi = np.interp(tt, t, np.cumsum(speed) / FS) + 0.3  # any constant
    out = refine_with_angles(drive, tt, phi)
    assert out.speed(np.array([0.0]))[0] == pytest.approx(5.0, abs=0.1)
    assert out.speed(np.array([2.0]))[0] == pytest.approx(3.0, abs=0.01)


def test_a_start_from_rest_is_kept_where_the_first_stick_is_no_whole_cycle() -> None:
    # the drive starts from rest at t = 0; the discs stick while the belt winds up
    # (0.15 s), then 12 ms stick-slip cycles at 3 rad/s: the part before the first
    # cycle is no cycle mean, but the profile must not begin at speed
    rng = np.random.default_rng(12)
    t = np.arange(0.0, 3.0, 1e-4)
    speed = rng.normal(0.0, 0.01, t.size)
    after = t >= 0.15
    w = np.zeros(int(after.sum()))
    t0 = 0.0
    ta = t[after] - 0.15
    while t0 < ta[-1]:
        i = (ta >= t0) & (ta < t0 + 0.012)
        s = (ta[i] - t0) / 0.0036
        w[i] = np.where(s < 1.0, 0.5 * np.pi * 3.0 / 0.3 * np.sin(np.pi * np.clip(s, 0, 1)), 0.0)
        t0 += 0.012
    speed[after] += w
    est = estimate_drive(t, speed, 3.0)
    assert float(est.speed(np.array([0.0]))[0]) < 1.5


def test_a_start_from_rest_gets_the_ramps_end_as_a_corner_without_a_knot_near_it() -> None:
    # the drive ramps 0 -> 0.4 rad/s over 0.105 s (RIG.yaml's ramp) and steps to
    # 0.8 rad/s at 2.5 s; the profile to refine has no knot near the ramp's end
    t = np.arange(0.0, 4.0, 1.0 / FS)
    truth = np.interp(t, [0.0, 0.105, 2.5, 2.56, 4.0], [0.0, 0.4, 0.4, 0.8, 0.8])
    drive = DriveEstimate(
        np.array([0.0, 2.45, 2.6, 4.0]), np.array([0.36, 0.36, 0.78, 0.78]), 0.4, 0.4, 0.0, True
    )
    tt = np.arange(0.01, 3.99, 0.002)
    phi = np.interp(tt, t, np.cumsum(truth) / FS)
    out = refine_with_angles(drive, tt, phi, np.array([0.0, 0.105]), start_speed=0.0)
    assert np.min(np.abs(out.knot_time - 0.105)) < 1e-9
    # the plateau between the ramp and the step keeps the drive's 0.4 rad/s
    assert np.max(np.abs(out.speed(np.arange(0.2, 2.4, 0.01)) - 0.4)) < 0.01


@pytest.mark.parametrize('offset', [0.0, 0.006])
def test_a_start_after_a_wait_is_placed_free_of_a_speed_offset(offset: float) -> None:
    # rest for 0.41 s, a ramp to 0.355 rad/s over 0.1 s (random record 30); the
    # tachometer's offset drifts the angles by offset*t. Without a pinned start speed
    # (the wait's angles pin it) the offset only shifts the knot speeds: the corners
    # within 0.2 ms of the truth, the wait's speed at the offset (1e-5 rad/s). Pinned
    # at 0 (start_speed), the drift moved the ramp's start 3.1 ms early for 0.006 rad/s
    t = np.arange(0.0, 2.0, 1.0 / FS)
    truth = np.interp(t, [0.0, 0.41, 0.51, 2.0], [0.0, 0.0, 0.355, 0.355])
    drive = DriveEstimate(
        np.array([0.0, 0.40, 0.52, 2.0]), np.array([0.0, 0.0, 0.355, 0.355]), 0.355, 0.355,
        0.0, True,
    )  # fmt: skip
    tt = np.arange(0.01, 1.99, 0.002)
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (truth[1:] + truth[:-1])) / FS))
    phi = np.interp(tt, t, angle) + offset * tt
    out = refine_with_angles(drive, tt, phi)
    for corner in (0.41, 0.51):
        assert np.min(np.abs(out.knot_time - corner)) < 2e-4, corner
    assert float(out.speed(np.array([0.2]))[0]) == pytest.approx(offset, abs=1e-5)


def test_the_corners_of_many_transitions_are_placed_to_the_angles() -> None:
    # five transitions (ten corners: a stop, a rest, a start, a step down, a step up, a
    # stop) with the drive angles of every 2 ms: each corner within 1 ms of the truth,
    # the profile within 0.01 rad/s of it. With at most 8 corners placed the corners
    # stayed where the smoothed speed channel put them, 30 ms and 0.5 rad/s off
    corners = [1.0, 1.3, 2.0, 2.2, 3.0, 3.1, 4.0, 4.2, 5.0, 5.4]
    levels = [2.0, 2.0, 0.0, 0.0, 3.0, 3.0, 1.5, 1.5, 2.5, 2.5, 0.0]
    knots_t = [0.0, *corners, 6.0]
    knots_v = [levels[0], *levels[1:], 0.0][: len(knots_t)]
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 6.0, 1.0 / FS)
    truth = np.interp(t, knots_t, knots_v)
    drive = estimate_drive(t, truth + rng.normal(0.0, 0.02, t.size))
    tt = np.arange(0.01, 5.99, 0.002)
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (truth[1:] + truth[:-1])) / FS))
    phi = np.interp(tt, t, angle) + rng.normal(0.0, 1e-5, tt.size)
    out = refine_with_angles(drive, tt, phi)
    for corner in corners:
        assert np.min(np.abs(out.knot_time - corner)) < 1e-3, corner
    grid = np.arange(0.05, 5.95, 0.01)
    assert np.max(np.abs(out.speed(grid) - np.interp(grid, knots_t, knots_v))) < 0.01


def test_the_profile_angle_is_the_integral_of_its_speed() -> None:
    """Over a profile with a raised-cosine and a linear piece and beyond both ends, the
    angle from the first knot is the trapezoidal integral of the speed on a 10 us grid
    (to 1e-9 rad), zero at the first knot."""
    from tribo_estimation.core.drive import COSINE, DriveEstimate

    d = DriveEstimate(
        np.array([0.0, 1.0, 1.5, 3.0]), np.array([1.0, 1.0, 3.0, 2.0]), math.nan, 1.0,
        math.nan, shape=np.array([0.0, COSINE, 0.0, 0.0]),
    )  # fmt: skip
    t = np.linspace(-0.5, 3.5, 400_001)
    w = d.speed(t)
    swept = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))))
    angle = d.angle(t)
    assert np.max(np.abs(angle - (swept + angle[0]))) < 1e-9
    assert float(d.angle(0.0)) == 0.0
    assert angle[0] == pytest.approx(-0.5, abs=1e-12)


def test_a_duration_with_a_shape_shapes_its_pair_only() -> None:
    from tribo_estimation.core.drive import COSINE, transitions

    drive = _stepped([0.0, 1.0, 1.03, 1.5, 3.0])
    assert transitions(drive) == [1]
    # the pair 1.0-1.03 s becomes a raised cosine of 20 ms about its mid-time; the other
    # pieces stay linear, the speeds are kept
    d = with_durations(drive, ((1.015, 0.02, COSINE),))
    assert d.knot_time == pytest.approx([0.0, 1.005, 1.025, 1.5, 3.0], abs=1e-12)
    assert d.shapes().tolist() == [0.0, COSINE, 0.0, 0.0, 0.0]
    assert np.array_equal(d.knot_speed, drive.knot_speed)
    # and back to a line
    assert with_durations(d, ((1.015, 0.02, 0.0),)).shapes().tolist() == [0.0] * 5


def _s_ramps(t: np.ndarray) -> np.ndarray:
    """2.5 rad/s, an S-ramp to rest at 2.0-2.5 s, at rest, an S-ramp back at 4.0-4.8 s."""
    down = np.clip((t - 2.0) / 0.5, 0.0, 1.0)
    up = np.clip((t - 4.0) / 0.8, 0.0, 1.0)
    return 2.5 * (1.0 - 0.5 * (1.0 - np.cos(np.pi * down)) + 0.5 * (1.0 - np.cos(np.pi * up)))


def test_a_stop_and_a_restart_through_s_ramps_are_one_raised_cosine_each() -> None:
    # a motor controller's S-ramps of 0.5 and 0.8 s, stick phases every 20 ms while the
    # drive turns (angles for 6 ms of each) and throughout the rest, angle noise 5e-5 rad:
    # each ramp is one raised-cosine piece, its ends within 3 ms of the truth, and the
    # profile within 0.005 rad/s of it. Four linear pieces per ramp (the corners'
    # merge judged where they were, 9 corners above the 8 shaped) missed by 0.1 rad/s
    rng = np.random.default_rng(21)
    t = np.arange(0.0, 6.0, 1e-4)
    truth = _s_ramps(t)
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (truth[1:] + truth[:-1])) * 1e-4))
    speed = truth + rng.normal(0.0, 0.01, t.size)
    drive = estimate_drive(t[::10], speed[::10])
    turning = truth > 1e-6
    stuck = ~turning | (np.mod(t, 0.02) < 0.006)
    pick = np.flatnonzero(stuck)[::4]
    phi = angle[pick] + rng.normal(0.0, 5e-5, pick.size)
    out = refine_with_angles(drive, t[pick], phi)
    for a, b in ((2.0, 2.5), (4.0, 4.8)):
        (j,) = np.flatnonzero(np.abs(out.knot_time - a) < 3e-3)
        assert out.shapes()[j] == COSINE, out
        assert out.knot_time[j + 1] == pytest.approx(b, abs=3e-3), out
    grid = np.arange(0.05, 5.95, 0.005)
    assert np.max(np.abs(out.speed(grid) - _s_ramps(grid))) < 0.005
