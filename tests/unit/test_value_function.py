"""The value-function measures score every W at the same z and in the same coordinates."""
import numpy as np
import pytest

from orchestration.study import value_function as vf
from orchestration.study.sotc_study import PAPER_W


@pytest.mark.parametrize("W", [np.zeros(10), PAPER_W, np.linspace(-0.3, 0.5, 10)])
def test_state_at_places_the_core_at_the_asked_z(W):
    core = vf._core(W)
    k = [core.output_names().index(n) for n in ("z1", "z2", "z3", "z4")]
    for z, phi2 in vf.grid_points()[::53]:
        core.evaluate(*vf.state_at(core, z, phi2))
        assert np.allclose([core.outputs[i] for i in k], z, rtol=0, atol=1e-12)


def test_shared_z_is_own_z_for_w_zero_and_not_for_another_w():
    def gap(W):
        res = vf.simulate(vf._core(W), stop_time=2.0, phi0=(0.7, 0.9), dphi0=(0.1, -0.2))
        own = res.outputs[:, [res.names.index(n) for n in ("z1", "z2", "z3", "z4")]]
        return float(np.max(np.abs(vf.shared_z(res) - own)))

    assert gap(np.zeros(10)) < 1e-10  # rounding only: z_v is dphi - (dphi_d - e) in the core
    assert gap(PAPER_W) > 1e-3  # z_v = e_dot + e - chi_vd*(W): the shift the shared z removes


def test_residual_depends_on_z_and_phi2_only():
    """The same (z, phi2) reached with another reference gives the same e1 (so grid points are z points)."""
    core = vf._core(PAPER_W)
    k = core.output_names().index("e1")
    z, phi2 = (0.1, -0.05, 0.2, 0.0), 1.4
    t, y, r = vf.state_at(core, z, phi2)
    core.evaluate(t, y, r)
    first = core.outputs[k]
    shift = 0.3  # move the reference and the state together: e, e_dot unchanged
    core.evaluate(t, (y[0] + shift, y[1], y[2] + 0.5, y[3]), (r[0] + shift, r[1], r[2] + 0.5, r[3], 0.7, -0.2))
    assert core.outputs[k] == pytest.approx(first, rel=1e-12)


def test_value_rows_short_horizon():
    from orchestration.study.sotc_study import run

    ctrl, res = run("paper", stop_time=5.0)
    rows = vf.value_rows(np.array(ctrl.W), res, horizon=2.0)
    assert [r.label for r in rows] == ["learned W", "W = 0", "the paper's W", "LQR"]
    zero, lqr = rows[1], rows[3]
    assert all(v == 1.0 for v in zero.residuals)  # the reference of every residual column
    assert lqr.residuals[0] < 0.1  # LQR solves the HJB equation near z = 0
    assert zero.omega_cost.sum() < 1e-6 * lqr.omega_cost.sum()  # mu_hat(0) = 0 (W drifts by alpha = 1e-9 only)
    assert np.all(lqr.omega_cost > 0.0)
    report = vf.value_report(rows)
    assert report.count("| learned W |") == 2 and "- Residual:" in report and "- Cost-to-go:" in report
