"""Research runs of the SOTC core in the pure loop: the numbers quoted in ``docs/paper-notes.md``.

    python -m orchestration.study.sotc_study settings           # the three section-4 settings
    python -m orchestration.study.sotc_study readings           # each paper-gap alternative vs the chosen reading
    python -m orchestration.study.sotc_study stack              # CL stack rank/eigenvalues after the PE window
    python -m orchestration.study.sotc_study lqr                # learned W vs the LQR value of the linearised errors
    python -m orchestration.study.sotc_study euler              # stability margin of explicit Euler for (30)/(31)
    python -m orchestration.study.sotc_study chidot             # accuracy of dchi_vd/dt in tau^a
    python -m orchestration.study.sotc_study replay             # current vs recorded CL replay
    python -m orchestration.study.sotc_study robust [--set NAME=VALUE ...]   # small perturbations of `paper`
    python -m orchestration.study.sotc_study substeps           # `paper` vs the plant's RK4 substeps
    python -m orchestration.study.sotc_study weights [--setting S] [--set NAME=VALUE ...]   # W over time
    python -m orchestration.study.sotc_study timing             # evaluate + advance cost per step

Every run: 100 s, T = 0.01 s, section 4's initial state (``paper_setting.INITIAL_STATE``),
CircleTrajectory(), plant = controller model = ArmParameters() (the paper's), rk4_step with
``paper_setting.SUBSTEPS`` substeps.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_math import N_BASIS, matrix_to_weights, weights_to_matrix
from fmu_controller.riccati import solve_care
from fmu_plant.dynamics import STEP_SIZE, TORQUE_LIMIT, ArmParameters, inertia_entries, solve_inertia
from fmu_plant.paper_setting import INITIAL_STATE
from orchestration.run.metrics import weight_total_variation
from orchestration.run.scenario import available_scenarios, load_scenario
from orchestration.study import ordered
from orchestration.study.comparison import PAPER_TABLE1, TABLE1_MARGIN
from orchestration.study.pure_loop import LoopResult, metrics, simulate

PAPER_W = np.array([0.4303, -0.6671, -0.148, 0.0157, 1.14, -0.0216, 0.1913, 0.0074, 0.0284, 0.01572])
TARGET = {"mse1": TABLE1_MARGIN * PAPER_TABLE1["SOTC"][0], "mse2": TABLE1_MARGIN * PAPER_TABLE1["SOTC"][1],
           "max_late_e1": 1.5e-3, "max_late_e2": 1.5e-3, "max_tau_norm": TORQUE_LIMIT}


def setting_params(setting: str) -> dict[str, float]:
    """The SOTC parameters of a scenario file (orchestration/run/scenarios/<setting>.toml)."""
    return dict(load_scenario(setting).instances["controller"].parameters)


def sotc_settings() -> list[str]:
    """The scenarios whose controller is the SOTC in the plain paper loop (plant, reference,
    controller; the pure loop has no place for e.g. paper-perturbed's disturbance and noise FMUs)."""
    plain = {"plant", "reference", "controller"}
    return [n for n in available_scenarios()
            if (sc := load_scenario(n)).controller_fmu() == "SotcController" and set(sc.instances) == plain]


def run(setting: str = "paper", stop_time: float = 100.0, **overrides: float) -> tuple[SotcCore, LoopResult]:
    params = setting_params(setting)
    params.update(overrides)
    ctrl = SotcCore(**params)
    return ctrl, simulate(ctrl, stop_time=stop_time)


def stack_min_eig(ctrl: SotcCore) -> float:
    """lambda_min of the CL matrix M at the controller's current weights (0 for an empty stack)."""
    return ctrl.stack.min_eig_at(list(ctrl.W))


def weights(res: LoopResult) -> np.ndarray:
    i = res.names.index("W1")
    return res.outputs[:, i:i + 10]


def weight_variation(res: LoopResult, t0: float, t1: float) -> float:
    """Total variation sum_k ||W_{k+1} - W_k||_2 of the critic weights over [t0, t1]."""
    return weight_total_variation(res.t, weights(res), t0, t1)


def lqr_weights(phi2: float, ctrl: SotcCore, arm: ArmParameters | None = None) -> np.ndarray:
    """W of the LQR value z^T S z of the error dynamics (6)/(7) linearised at z = 0 with the
    configuration frozen at phi2 (g_v = D^-1(phi2)). Near mu = 0, Omega(mu) = sum r_i mu_i^2 + O(mu^4),
    so the cost (12) becomes z^T Theta z + mu^T R mu. S comes from the fixed-order Newton-Kleinman solver
    (``fmu_controller.riccati``), started from the gain that makes A - B K_0 = -I, and D^-1 from
    ``solve_inertia``: no LAPACK, so the value study prints the same bits under every BLAS kernel."""
    arm = arm or ctrl.model
    (l1, l2), (m1, m2) = ctrl.lam1, ctrl.lam2
    A = np.zeros((4, 4))
    if ctrl.backstepping:
        A[:2, :2] = -np.diag([l1, l2])
        A[:2, 2:] = np.eye(2)
    else:
        A[:2, 2:] = np.diag([1.0 + l1, 1.0 + l2])
    A[2:, :2] = -np.eye(2)
    A[2:, 2:] = -np.diag([m1, m2])
    if ctrl.fv_drift:  # d/dz_v of -D(z_phi)^-1 G(z_v) at z = 0: the columns D(0)^-1 (f_i + b_i) e_i
        A[2:, 2] -= solve_inertia(0.0, arm.f1 + arm.b1, 0.0, arm)
        A[2:, 3] -= solve_inertia(0.0, 0.0, arm.f2 + arm.b2, arm)
    B = np.zeros((4, 4))
    B[:2, :2] = np.eye(2)
    B[2:, 2] = solve_inertia(phi2, 1.0, 0.0, arm)
    B[2:, 3] = solve_inertia(phi2, 0.0, 1.0, arm)
    stabilising = np.eye(4) + A  # K_0 = B^-1 (A + I), B^-1 = diag(I, D(phi2))
    d11, d12, d22 = inertia_entries(phi2, arm)
    stabilising[2:] = [[d11 * a + d12 * b for a, b in zip(*stabilising[2:])],
                       [d12 * a + d22 * b for a, b in zip(*stabilising[2:])]]
    return matrix_to_weights(solve_care(A, B, np.diag(ctrl.theta), np.diag(ctrl.r), stabilising))


def fmt(m: dict[str, float]) -> str:
    return "  ".join(f"{k}={v:.4g}{'' if v <= TARGET[k] else '!'}" for k, v in m.items())


def cmd_settings(_: argparse.Namespace) -> None:
    for name in sotc_settings():
        ctrl, res = run(name)
        m = metrics(res)
        print(f"{name:14s} {fmt(m)}")
        print(f"{'':14s} W(100) = {np.round(ctrl.W, 4).tolist()}")
        print(f"{'':14s} weight TV [0,0.4]={weight_variation(res, 0, 0.4):.3g}"
              f"  [40,80]={weight_variation(res, 40, 80):.3g}"
              f"  [80,100]={weight_variation(res, 80, 100):.3g}   ||W(80)-W(40)||="
              f"{ordered.norm(weights(res)[8000] - weights(res)[4000]):.3g}")
        print(f"{'':14s} stack: size={ctrl.stack.count} lambda_min={stack_min_eig(ctrl):.3g}  tau_a bounded "
              f"{res.out('tau_a_bounded').mean():.2%} of samples, tau limited {res.out('tau_limited').mean():.2%},"
              f" law (31) {np.mean(res.out('tuning_law') == 31):.2%}")


# the critic frozen at its initial weights (the "no learning" readings, and the README verdict)
NO_LEARNING: dict[str, float] = {"alpha1": 1e-9, "alpha2": 1e-9}

READINGS: list[tuple[str, dict[str, float]]] = [
    ("chosen reading", {}),
    ("chi_a: as printed, +Lambda1 z_v", {"chi_a_form": 1}),
    ("F_v(z_phi, z_v) := 0", {"fv_error_form": 1}),
    ("bound (5): radial (Euclidean proj.)", {"limit_handling": 0}),
    ("bound (5) per joint, |tau_i| <= rho", {"limit_handling": 1, "actuator_form": 1}),
    ("bound (5) per joint, ||tau|| <= rho", {"limit_handling": 1}),
    ("saturation level rho in (13)/(28)", {"saturation_form": 1}),
    ("dchi_vd/dt: d(chi_vd^a)/dt only", {"chi_dot_form": 1}),
    ("dchi_vd/dt: backward difference", {"chi_dot_form": 2}),
    ("PE also inside the critic's mu_hat", {"pe_form": 1}),
    ("CL stack: first P records, frozen", {"cl_selection": 1}),
    ("CL stack: newest P (FIFO)", {"cl_selection": 2}),
    ("CL replay: recorded eta_i, r_i", {"cl_replay": 1}),
    ("W update: explicit Euler", {"weight_integrator": 1}),
    ("explicit Euler + FIFO stack", {"weight_integrator": 1, "cl_selection": 2}),
    ("CL from the end of PE (0.4 s)", {"cl_start_time": 0.4}),
    ("eta from (7) as printed (no coupling terms)", {"eta_form": 1}),
    ("CL from 0.4 s and eta as printed", {"cl_start_time": 0.4, "eta_form": 1}),
    ("no CL", {"cl_enabled": 0}),
    ("no learning (alpha1 = alpha2 = 1e-9)", NO_LEARNING),
    ("no learning, F_v(z_phi, z_v) := 0", {**NO_LEARNING, "fv_error_form": 1}),
    ("no learning, bound (5) radial", {**NO_LEARNING, "limit_handling": 0}),
    ("as printed throughout", {"chi_a_form": 1, "limit_handling": 0, "saturation_form": 1, "cl_selection": 1,
                               "cl_replay": 1, "weight_integrator": 1}),
]


def cmd_readings(args: argparse.Namespace) -> None:
    for label, ov in READINGS:
        ctrl, res = run(args.setting, **ov)
        print(f"{label:36s} {fmt(metrics(res))}  lambda_min={stack_min_eig(ctrl):.2g}")


def cmd_stack(args: argparse.Namespace) -> None:
    for label, ov in [("chosen (max-lambda_min swaps)", {}), ("first P records, frozen", {"cl_selection": 1}),
                      ("newest P (FIFO)", {"cl_selection": 2})]:
        ctrl, res = run(args.setting, stop_time=args.stop, **ov)
        st = ctrl.stack
        E = np.array(st.rows["eta"]).reshape(st.P, -1)[:st.count]
        sv = ordered.singular_values(E)
        st.terms(list(ctrl.W))
        M = np.array(st.M).reshape(len(ctrl.W), -1)
        Xi = E / (1.0 + np.array([ordered.norm(row) ** 2 for row in E]))[:, None] ** 2
        print(f"{label} at t={args.stop:g}s: P={st.count}, rank(eta_1..eta_P)={ordered.rank(E)}"
              f" (Gram matrix, max(shape) eps tolerance), singular values {np.array2string(sv, precision=2)}")
        print(f"   eig of sum xi_i eta_i^T (recorded)  {np.array2string(ordered.eigvalsh(ordered.product(Xi.T, E)), precision=2)}")
        print(f"   eig of sum xi_i eta_i^T (replayed)  {np.array2string(ordered.eigvalsh(M), precision=2)}")
        print(f"   ||z_i|| {np.array2string(np.array([ordered.norm(z) for z in np.array(st.rows['z']).reshape(st.P, 4)[:st.count]]), precision=2)}")


def cmd_lqr(args: argparse.Namespace) -> None:
    ctrl0 = SotcCore()
    phi2s = np.linspace(0.5879, 2.1921, 5)  # range of phi2_d on the circle
    refs = {f"{p:.2f}": lqr_weights(p, ctrl0) for p in phi2s}
    print("LQR W at frozen phi2 (rad):")
    for k, w in refs.items():
        print(f"  phi2={k}: {np.round(w, 4).tolist()}")
    mid = lqr_weights(float(np.mean(phi2s)), ctrl0)
    print(f"paper's W: eig S(W) = {np.round(ordered.eigvalsh(weights_to_matrix(PAPER_W)), 4).tolist()}"
          f"  ||W_paper - W_lqr(mid)|| = {ordered.norm(PAPER_W - mid):.3g} (||W_lqr|| = {ordered.norm(mid):.3g})")
    for setting in sotc_settings():
        for label, ov in [("", {}), ("stored replay", {"cl_replay": 1})]:
            ctrl, res = run(setting, **ov)
            W = np.array(ctrl.W)
            d = [ordered.norm(W - w) for w in refs.values()]
            print(f"{setting:14s} {label:14s} W(100)={np.round(W, 4).tolist()}")
            eig = np.round(ordered.eigvalsh(weights_to_matrix(W)), 4).tolist()
            print(f"{'':29s} ||W-W_lqr|| over phi2 = {np.round(d, 3).tolist()} (rel. to mid {d[2] / ordered.norm(mid):.2f});"
                  f" ||W-W_paper||={ordered.norm(W - PAPER_W):.3g}; eig S(W)={eig};"
                  f" lambda_min(stack)={stack_min_eig(ctrl):.2g}")


def cmd_euler(args: argparse.Namespace) -> None:
    """Largest T alpha1 lambda_max(Gamma), Gamma = xi eta^T + M, seen along the run (explicit Euler of
    (30)/(31) is stable only below 2)."""
    from fmu_plant.dynamics import rk4_step
    from fmu_plant.trajectory import CircleTrajectory

    traj, arm = CircleTrajectory(), ArmParameters()
    for label, ov in [("chosen (max-lambda_min swaps)", {}), ("first P records, frozen", {"cl_selection": 1}),
                      ("newest P (FIFO)", {"cl_selection": 2})]:
        for integ in (0, 1):
            ctrl = SotcCore(weight_integrator=integ, **ov)
            state, worst, t_worst = INITIAL_STATE, 0.0, 0.0
            for k in range(int(round(args.stop / STEP_SIZE))):
                t = k * STEP_SIZE
                ctrl.evaluate(t, state, traj.sample(t)[:6])
                pend = ctrl._pending
                M = np.array(ctrl.stack.M).reshape(N_BASIS, N_BASIS) if pend["cl"] else 0.0  # the CL sum's M W + b
                G = np.outer(pend["xi"], pend["eta"]) + M
                lam = STEP_SIZE * ctrl.alpha1 * ordered.eigvalsh(0.5 * (G + G.T))[-1]
                if lam > worst:
                    worst, t_worst = lam, t
                state = rk4_step(state, ctrl.outputs[0], ctrl.outputs[1], STEP_SIZE, 4, arm)
                ctrl.advance(t, STEP_SIZE)
            e = np.array(state[:2]) - np.array(traj.sample(args.stop)[:2])
            print(f"{label:30s} {'implicit' if integ == 0 else 'Euler':8s} max T alpha1 lambda_max(Gamma) = {worst:.3g}"
                  f" at t = {t_worst:.2f} s; ||W({args.stop:g})|| = {ordered.norm(ctrl.W):.3g}, |e({args.stop:g})| = "
                  f"{np.array2string(np.abs(e), precision=2)}")


def cmd_chidot(_: argparse.Namespace) -> None:
    """RMS of (dchi_vd/dt used in tau^a) - (central difference of the chi_vd produced), per joint."""
    for label, form in [("chain rule", 0), ("d(chi_vd^a)/dt only", 1), ("backward difference", 2)]:
        _, res = run("paper", chi_dot_form=form)
        chi = np.column_stack([res.out("chi_vd_star1") + res.out("chi_vd_a1"),
                               res.out("chi_vd_star2") + res.out("chi_vd_a2")])
        central = (chi[2:] - chi[:-2]) / 0.02
        used = np.column_stack([res.out("dchi_vd1"), res.out("dchi_vd2")])[1:-1]
        tt = res.t[1:-1]
        parts = []
        for a, b in [(0.0, 3.0), (3.0, 100.0)]:
            m = (tt >= a) & (tt < b)
            err = np.sqrt(np.mean((used[m] - central[m]) ** 2, axis=0))
            ref = np.sqrt(np.mean(central[m] ** 2, axis=0))
            parts.append(f"[{a:g},{b:g}) s: rms err {err[0]:.2g} / {err[1]:.2g} (rms dchi {ref[0]:.2g} / {ref[1]:.2g})")
        print(f"{label:22s} " + "; ".join(parts))


def cmd_weights(args: argparse.Namespace) -> None:
    """Total variation of W per time window, and W at a few instants."""
    overrides = {k: float(v) for k, v in (kv.split("=", 1) for kv in args.set)}
    _, res = run(args.setting, **overrides)
    W = weights(res)
    edges = [0, 0.4, 2, 10, 20, 40, 60, 80, 100]
    windows = zip(edges, edges[1:])
    print("TV per window: " + ", ".join(f"[{a:g},{b:g}] {weight_variation(res, a, b):.3g}" for a, b in windows))
    for t in (0.4, 1, 2, 5, 10, 50, 100):
        print(f"  W({t:g}) = {np.round(W[int(round(t / STEP_SIZE))], 4).tolist()}")


ROBUSTNESS: list[dict[str, float]] = [
    {}, {"pe_amplitude": 0.45}, {"pe_amplitude": 0.49}, {"pe_amplitude": 0.51}, {"pe_amplitude": 0.55},
    {"alpha1": 40.0}, {"alpha1": 60.0}, {"cl_record_interval": 0.01}, {"cl_record_interval": 0.03},
    {"weight_integrator": 1}, {"cl_replay": 1}, {"chi_dot_form": 2}, {"pe_form": 1},
]


def cmd_robust(args: argparse.Namespace) -> None:
    """Small perturbations of the `paper` setting, for a reading given by --set (default: chosen)."""
    base = {k: float(v) for k, v in (kv.split("=", 1) for kv in args.set)}
    for ov in ROBUSTNESS:
        _, res = run("paper", **base, **ov)
        w5 = weights(res)[res.t <= 3.0, 4]
        print(f"{str(ov):32s} {fmt(metrics(res))}  min W5 on [0,3] s = {w5.min():.3f}")


def cmd_substeps(_: argparse.Namespace) -> None:
    """The `paper` figures for several RK4 substep counts of the plant."""
    for n in (1, 2, 4, 8, 16):
        print(f"substeps={n:2d} {fmt(metrics(simulate(SotcCore(), substeps=n)))}")


def cmd_replay(_: argparse.Namespace) -> None:
    """Current vs recorded CL replay: weight TV over [40, 80] s and distance to W_lqr, in a few variants."""
    for setting in ("paper", "paper-long-pe"):
        for ov in ({}, {"weight_integrator": 1}, {"pe_amplitude": 0.25}):
            for replay in (0, 1):
                ctrl, res = run(setting, cl_replay=replay, **ov)
                d = ordered.norm(np.array(ctrl.W) - lqr_weights(1.39, ctrl))
                print(f"{setting:14s} {str(ov):26s} replay={'current ' if replay == 0 else 'recorded'}"
                      f" TV[40,80]={weight_variation(res, 40, 80):.3f}  ||W-W_lqr||={d:.3f}  {fmt(metrics(res))}")


def cmd_timing(_: argparse.Namespace) -> None:
    ctrl, res = run("paper")
    for setting in sotc_settings():
        c = SotcCore(**setting_params(setting))
        ys, rs = res.y.tolist(), res.ref[:, :6].tolist()
        t0 = time.perf_counter()
        for k in range(len(ys) - 1):
            c.evaluate(k * STEP_SIZE, ys[k], rs[k])
            c.advance(k * STEP_SIZE, STEP_SIZE)
        dt = (time.perf_counter() - t0) / (len(ys) - 1)
        print(f"{setting:14s} evaluate+advance: {dt * 1e6:.1f} us per step")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("settings").set_defaults(fn=cmd_settings)
    p = sub.add_parser("readings")
    p.add_argument("--setting", default="paper", choices=sotc_settings())
    p.set_defaults(fn=cmd_readings)
    p = sub.add_parser("stack")
    p.add_argument("--setting", default="paper", choices=sotc_settings())
    p.add_argument("--stop", type=float, default=0.5)
    p.set_defaults(fn=cmd_stack)
    sub.add_parser("lqr").set_defaults(fn=cmd_lqr)
    sub.add_parser("timing").set_defaults(fn=cmd_timing)
    sub.add_parser("chidot").set_defaults(fn=cmd_chidot)
    sub.add_parser("replay").set_defaults(fn=cmd_replay)
    sub.add_parser("substeps").set_defaults(fn=cmd_substeps)
    p = sub.add_parser("robust")
    p.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE", help="reading to perturb")
    p.set_defaults(fn=cmd_robust)
    p = sub.add_parser("weights")
    p.add_argument("--setting", default="paper", choices=sotc_settings())
    p.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE", help="parameter overrides")
    p.set_defaults(fn=cmd_weights)
    p = sub.add_parser("euler")
    p.add_argument("--stop", type=float, default=30.0)
    p.set_defaults(fn=cmd_euler)
    args = ap.parse_args(argv)
    args.fn(args)


if __name__ == "__main__":
    main()
