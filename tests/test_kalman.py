"""The closed-form filters of positioning agree with filterpy's KalmanFilter step by step."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol.positioning.fixerror import (
    UNKNOWN_LAG_VAR_M2,
    FixErrorState,
    fix_error_predict,
    fix_error_update,
)
from antikol.positioning.kalman import (
    TrackFilterState,
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
        st.tuples(
            st.floats(0.1, 10.0),  # dt, s
            st.floats(0.0, 2 * np.pi),  # track heading, rad
            st.floats(-8.0, 8.0),  # lateral offset of the fix, m
            st.floats(-15.0, 15.0),  # distance predicted minus distance between fixes, m
            st.floats(0.0, 30.0),  # variance of the predicted distance, m²
            st.sampled_from([1.0, -1.0]),  # running direction
        ),
        min_size=1,
        max_size=10,
    )
)
@settings(max_examples=150, deadline=None)
def test_fix_error_filter_matches_filterpy(seq):
    # state (lag a, bias east, bias north); the lateral offset measures n·b, the fix's place
    # along the track measures a + t·b (as 0, the lag being kept relative to the fix)
    sigma_b, tau, noise = 2.5, 60.0, 9.0
    ref = KalmanFilter(dim_x=3, dim_z=1)
    ref.x = np.zeros((3, 1))
    ref.P = np.diag([UNKNOWN_LAG_VAR_M2, sigma_b**2, sigma_b**2])
    ours = FixErrorState.start(1, sigma_b)
    for dt, angle, lateral, shift, run_var, direction in seq:
        rho = np.exp(-dt / tau)
        ref.predict(
            F=np.diag([1.0, rho, rho]),
            Q=np.diag([run_var, sigma_b**2 * (1 - rho**2), sigma_b**2 * (1 - rho**2)]),
            u=np.array([[shift]]),
            B=np.array([[1.0], [0.0], [0.0]]),
        )
        ours = fix_error_predict(
            ours, np.array([dt]), sigma_b, tau, np.array([shift]), np.array([run_var])
        )
        nx, ny = -np.cos(angle), np.sin(angle)
        tx, ty = direction * np.sin(angle), direction * np.cos(angle)
        ref.update(np.array([[lateral]]), R=np.array([[noise]]), H=np.array([[0.0, nx, ny]]))
        lat_y, lat_s = ref.y[0, 0], ref.S[0, 0]
        ref.update(np.array([[0.0]]), R=np.array([[noise]]), H=np.array([[1.0, tx, ty]]))
        ours, lat, along = fix_error_update(
            ours,
            np.array([nx]),
            np.array([ny]),
            np.array([lateral]),
            np.array([tx]),
            np.array([ty]),
            np.array([noise]),
        )
        assert lat.residual_m[0] == pytest.approx(lat_y, abs=1e-9)
        assert lat.variance_m2[0] == pytest.approx(lat_s, rel=1e-9)
        assert along.residual_m[0] == pytest.approx(ref.y[0, 0], abs=1e-6)
        assert along.variance_m2[0] == pytest.approx(ref.S[0, 0], rel=1e-7)
        for k, name in enumerate(("ad", "bx", "by")):
            assert getattr(ours, name)[0] == pytest.approx(ref.x[k, 0], abs=1e-6)
        cov = (("paa", 0, 0), ("pax", 0, 1), ("pay", 0, 2), ("pxx", 1, 1), ("pxy", 1, 2))
        for name, r, c in (*cov, ("pyy", 2, 2)):
            assert getattr(ours, name)[0] == pytest.approx(ref.P[r, c], rel=1e-6, abs=1e-7)
