"""The floor under the FMI plumbing (``sotc-cosim bench``): empty pythonfmu FMUs with the same
variables as ours (every input, output and parameter, by name and type), whose ``do_step`` does
nothing. Run by the same master with the same instrumentation as the cost split, they leave
pythonfmu's C layer, fmpy's ctypes calls and pythonfmu's ``Fmi2Slave``: what no change to our
slaves can remove."""
from __future__ import annotations

from pathlib import Path

from fmpy import read_model_description

SCRIPT = '''from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real

VARIABLES = {variables!r}


class {model}(Fmi2Slave):
    """{model}'s variables, no behaviour."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, causality, kind, start in VARIABLES:
            setattr(self, name, start)
            var = (Integer if kind == "Integer" else Real)(
                name, causality=getattr(Fmi2Causality, causality),
                variability=Fmi2Variability.tunable if causality == "parameter" else None)
            self.register_variable(var)

    def do_step(self, current_time, step_size):
        return True
'''


def _variables(fmu: Path) -> list[tuple[str, str, str, float]]:
    md = read_model_description(str(fmu), validate=False)
    out = []
    for v in md.modelVariables:
        if v.causality in ("input", "output", "parameter") and v.type in ("Real", "Integer"):
            start = float(v.start) if v.start is not None else 0.0
            out.append((v.name, v.causality, v.type, int(start) if v.type == "Integer" else start))
    return out


def empty_fmus(paths: dict[str, Path], out_dir: Path) -> dict[str, Path]:
    """model -> an empty FMU with the variables of ``paths[model]``, built into ``out_dir``."""
    from pythonfmu.builder import FmuBuilder

    empty = {}
    for model, fmu in paths.items():
        script = Path(out_dir) / f"{model}.py"
        script.write_text(SCRIPT.format(model=model, variables=_variables(fmu)))
        empty[model] = Path(FmuBuilder.build_FMU(script, dest=out_dir))
    return empty
