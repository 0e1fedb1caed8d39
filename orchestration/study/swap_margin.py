"""Do the CL stack's swap decisions rest on rounding? Every offer re-decided with moved thresholds.

``FlipCountingStack`` is the controller's ``CLStack`` that, at each offer of a sample to the full stack
under ``maxeig``, decides as the core does and then twice more with every threshold (the margin at or
above which an eigenvalue counts, the least gain of lambda_k, the tie window) moved by +eps trace(M)
and by -eps trace(M), one rounding of M's scale. An offer where either re-decision picks another row
(or none) is a flip. With ``margin=ROUNDING`` (the earlier rule's tolerance n eps trace(M) in the place
of ``SWAP_MARGIN``) it measures today's rule with that tolerance; no selection of the core keeps it.

``flip_counts`` runs a configuration in the pure loop (``orchestration.study.pure_loop``) with this
stack in the SOTC core; ``cases`` are `paper` under every handling of the bound and every stored tuned
SOTC design (``orchestration.study.tuning``, every seed), ``stress_cases`` a few changes of radial
`paper` that keep the stack near rank deficiency or let it drift slowly, each on its nominal 100 s
`paper` loop. A flip is possible wherever a threshold is: the rule takes a swap once its gain clears
the threshold, so the best gain on offer creeps up to it from below, and when it creeps by less than
eps trace(M) per offer a rounding decides that one offer. The margin keeps decisions off rounding noise
(eigenvalues and ties at rounding level); the stress cases show the crossings that remain.
"""
from __future__ import annotations

import functools

from fmu_numerics.fixed_linalg import EPS, trace
from fmu_controller.saturation import RADIAL
from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_math import N_BASIS
from fmu_controller.sotc_stack import SWAP_MARGIN, CLStack
from orchestration.study.comparison import controller_of
from orchestration.study.pure_loop import simulate
from orchestration.study.tuning import HANDLINGS, stored, tuned_parameters

ROUNDING = N_BASIS * EPS  # the earlier rule's tolerance, relative to trace(M)
MARGINS = (SWAP_MARGIN, SWAP_MARGIN / 10.0, ROUNDING)  # the docs' table: the margin, a tenth of it, the earlier tolerance
STOP_TIME = 100.0  # s, the nominal `paper` loop


class FlipCountingStack(CLStack):
    """A ``CLStack`` that counts its offers and flips (see the module docstring); ``margin`` relative to
    trace(M)."""

    def __init__(self, stack: CLStack, margin: float = SWAP_MARGIN):
        super().__init__(stack.P, stack.selection, stack.replay_form, stack.constants)
        self.offers = self.flips = 0
        self.margin = margin

    def _swap_row(self, eta: list, spectrum: tuple[float, int, float], shift: float = 0.0) -> int:
        row = super()._swap_row(eta, spectrum, shift)
        delta = EPS * trace(self.M, N_BASIS)
        moved = [super(FlipCountingStack, self)._swap_row(eta, self.spectrum(s), s) for s in (delta, -delta)]
        self.offers += 1
        self.flips += any(r != row for r in moved)
        return row


# changes of `paper` that keep the stack near rank deficiency or let it drift slowly (under radial, the handling
# that flipped most)
STRESS = (("PE amplitude 5e-4", {"pe_amplitude": 5e-4}), ("no PE", {"pe_amplitude": 0.0}), ("P = 10", {"P": 10.0}),
          ("20 s of PE", {"pe_duration": 20.0}), ("records every 0.01 s", {"cl_record_interval": 0.01}))


def cases() -> list[tuple[str, int, dict[str, float]]]:
    """(label, limit handling, SOTC parameters): `paper` under each handling, then each stored tuned design."""
    out = [("`paper`", code, controller_of("paper", limit_handling=float(code))[1]) for code in HANDLINGS]
    for code in HANDLINGS:
        for seed in stored()["seeds"]:
            params = controller_of("paper", limit_handling=float(code), **tuned_parameters("SotcController", code, seed))[1]
            out.append((f"tuned SOTC, seed {seed}", code, params))
    return out


def stress_cases() -> list[tuple[str, int, dict[str, float]]]:
    """``cases``' form for the ``STRESS`` changes of radial `paper`."""
    return [(f"`paper`, {label}", RADIAL, controller_of("paper", limit_handling=float(RADIAL), **ov)[1])
            for label, ov in STRESS]


@functools.lru_cache(maxsize=None)
def flip_counts(params: tuple[tuple[str, float], ...], margin: float = SWAP_MARGIN,
                stop_time: float = STOP_TIME) -> dict[str, int]:
    """Offers to the full stack, swaps taken and flips of one SOTC configuration in the pure loop."""
    core = SotcCore(**dict(params))
    core.stack = stack = FlipCountingStack(core.stack, margin)
    simulate(core, stop_time=stop_time)
    return {"offers": stack.offers, "swaps": stack.swaps, "flips": stack.flips}
