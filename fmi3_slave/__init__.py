"""The FMI 3.0 face of the sotc-cosim slave framework: every FMI 3 FMU wraps the very FMI 2 model
class of ``fmi_slave`` (the same wrapper over the same core, with its parameter checks, refusal
messages, state checks and input checks) and presents it through pythonfmu3: scalars grouped into
arrays (``arrays``), FMI 3 types and the modelDescription (``model_description``), Model Exchange
where a model gives its state derivatives (``exchange``). Imports pythonfmu3, pythonfmu's Python
half (the variable model of ``fmi_slave``), ``fmi_slave`` and the standard library, never a core."""
