"""Configs as Python objects with the YAML's field names and defaults.

Nothing here lists a field: the defaults and the field descriptions come from the C++ field
tables (core/config_fields.hpp), and a config is validated by reading it through the same table
as a YAML file, so a wrong key or value raises hazmap.Error with the YAML's message.

    cfg = hazmap.Config("registration", max_iterations=30)
    cfg.metric                     # 'plane'
    hazmap.register(src, tgt, config=cfg)   # or config={"max_iterations": 30}
"""
from . import _hazmap

KINDS = ("registration", "odometry", "run", "graph", "simulator")


def defaults(kind, method="property-icp+pgo"):
    """The defaults of a config kind as a nested dict (for 'run', those of `method`)."""
    return _hazmap._config_info(kind, None, method)[0]


def fields(kind, method="property-icp+pgo"):
    """Field descriptions: name, type, doc, allowed, default (and nested fields for sections)."""
    return _hazmap._config_info(kind, None, method)[1]


def validate(kind, config, method="property-icp+pgo"):
    """The full config (defaults overridden by `config`), validated; raises hazmap.Error."""
    return _hazmap._config_info(kind, config, method)[2]


class _Section(dict):
    """A dict whose existing keys read and write as attributes; a new key is a typo, refused."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    def __setattr__(self, name, value):
        if name not in self:
            raise AttributeError(f"{self._owner()}no field '{name}'")
        self[name] = value

    def _owner(self):
        return ""


class Config(_Section):
    """A dict of one kind's complete config with attribute access; sections are Configs too.

    Built from the defaults, then `overrides` (a dict, possibly nested) and keyword arguments;
    validated at once, so typos fail here rather than in the run.
    """

    def __init__(self, kind, overrides=None, method="property-icp+pgo", **kwargs):
        merged = dict(overrides or {})
        merged.update(kwargs)
        super().__init__(_wrap(validate(kind, merged, method)))
        object.__setattr__(self, "kind", kind)

    def _owner(self):
        return f"{self.kind} config has "

    def to_dict(self):
        return _unwrap(self)


def _wrap(value):
    if isinstance(value, dict):
        return _Section({k: _wrap(v) for k, v in value.items()})
    return value


def _unwrap(value):
    if isinstance(value, dict):
        return {k: _unwrap(v) for k, v in value.items()}
    return value
