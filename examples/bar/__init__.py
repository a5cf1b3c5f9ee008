"""The AT1 bar in tension as a model kind: :mod:`examples.bar.model` (the model the engine
drives), :mod:`examples.bar.kind` (``kind = "bar"``), ``bar.toml`` (a scene of it) and
``python -m examples.bar`` (the command line with the kind registered)."""
