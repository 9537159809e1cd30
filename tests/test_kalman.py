"""The closed-form filters of positioning agree with filterpy's KalmanFilter step by step."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol.positioning.kalman import (
    BiasState,
    TrackFilterState,
    bias_predict,
    bias_update,
    track_estimate,
    track_predict,
    track_update,
)

steps = st.lists(
    st.tuples(
        st.floats(0.2, 5.0),  # dt, s
        st.floats(-50.0, 50.0),  # position innovation, m
        st.floats(0.0, 20.0),  # measured speed, m/s
        st.booleans(),  # with speed
    ),
    min_size=1,
    max_size=12,
)


@given(steps)
@settings(max_examples=150, deadline=None)
def test_along_track_filter_matches_filterpy(seq):
    accel, sig_s, sig_v = 0.6, 3.9, 0.3
    ref = KalmanFilter(dim_x=2, dim_z=2)
    ref.x = np.array([[0.0], [10.0]])
    ref.P = np.diag([sig_s**2, (2 * sig_v) ** 2])
    ref.H = np.eye(2)
    st_ = TrackFilterState.empty(1)
    st_.t[0], st_.s[0], st_.v[0] = 0.0, 0.0, 10.0
    st_.pss[0], st_.psv[0], st_.pvv[0] = sig_s**2, 0.0, (2 * sig_v) ** 2
    t = 0.0
    for dt, innov, v_meas, with_speed in seq:
        t += dt
        f = np.array([[1.0, dt], [0.0, 1.0]])
        ref.predict(F=f, Q=Q_discrete_white_noise(dim=2, dt=dt, var=accel**2))
        track_predict(st_, 0, t, accel)
        ref.x[1, 0] = max(ref.x[1, 0], 0.0)  # ours clamps a negative speed
        z_s = float(ref.x[0, 0]) + innov
        if with_speed:
            ref.update(np.array([[z_s], [v_meas]]), R=np.diag([sig_s**2, sig_v**2]))
            track_update(st_, 0, z_s, sig_s, v_meas, sig_v)
        else:
            ref.update(np.array([[z_s]]), R=np.array([[sig_s**2]]), H=np.array([[1.0, 0.0]]))
            track_update(st_, 0, z_s, sig_s, None, sig_v)
        ref.x[1, 0] = max(ref.x[1, 0], 0.0)
        assert st_.s[0] == pytest.approx(ref.x[0, 0], rel=1e-9, abs=1e-7)
        assert st_.v[0] == pytest.approx(ref.x[1, 0], rel=1e-9, abs=1e-7)
        assert st_.pss[0] == pytest.approx(ref.P[0, 0], rel=1e-9)
        assert st_.psv[0] == pytest.approx(ref.P[0, 1], rel=1e-9, abs=1e-12)
        assert st_.pvv[0] == pytest.approx(ref.P[1, 1], rel=1e-9)
    s, _, s_std, _ = track_estimate(st_, 0, t + 2.0, accel)
    f = np.array([[1.0, 2.0], [0.0, 1.0]])
    x = f @ ref.x
    p = f @ ref.P @ f.T + Q_discrete_white_noise(dim=2, dt=2.0, var=accel**2)
    assert s == pytest.approx(x[0, 0], abs=1e-7)
    assert s_std == pytest.approx(np.sqrt(p[0, 0]), rel=1e-9)


@given(
    st.lists(
        st.tuples(st.floats(0.1, 10.0), st.floats(0.0, 2 * np.pi), st.floats(-8.0, 8.0)),
        min_size=1,
        max_size=10,
    )
)
@settings(max_examples=150, deadline=None)
def test_bias_filter_matches_filterpy(seq):
    sigma_b, tau, noise = 2.5, 60.0, 9.0
    ref = KalmanFilter(dim_x=2, dim_z=1)
    ref.x = np.zeros((2, 1))
    ref.P = np.eye(2) * sigma_b**2
    ours = BiasState.prior(1, sigma_b)
    for dt, angle, lateral in seq:
        rho = np.exp(-dt / tau)
        ref.predict(F=np.eye(2) * rho, Q=np.eye(2) * sigma_b**2 * (1 - rho**2))
        ours = bias_predict(ours, np.array([dt]), sigma_b, tau)
        n = np.array([[np.cos(angle), np.sin(angle)]])
        ref.update(np.array([[lateral]]), R=np.array([[noise]]), H=n)
        ours, resid, var = bias_update(
            ours, np.array([n[0, 0]]), np.array([n[0, 1]]), np.array([lateral]), np.array([noise])
        )
        assert resid[0] == pytest.approx(ref.y[0, 0], abs=1e-9)
        assert var[0] == pytest.approx(ref.S[0, 0], rel=1e-9)
        assert ours.bx[0] == pytest.approx(ref.x[0, 0], abs=1e-9)
        assert ours.by[0] == pytest.approx(ref.x[1, 0], abs=1e-9)
        assert ours.pxx[0] == pytest.approx(ref.P[0, 0], rel=1e-7, abs=1e-12)
        assert ours.pxy[0] == pytest.approx(ref.P[0, 1], rel=1e-7, abs=1e-9)
        assert ours.pyy[0] == pytest.approx(ref.P[1, 1], rel=1e-7, abs=1e-12)
