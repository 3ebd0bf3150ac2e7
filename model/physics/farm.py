"""A farm as the rest of RAST uses it: a config validated
(:mod:`~rast.model.physics.config`) and its range-extended turbines split
into their delay taps (:mod:`~rast.model.physics.extended`)."""

from __future__ import annotations

from pathlib import Path

from rast.model.physics.config import ConfigError, Farm, read_config_file, validate_config
from rast.model.physics.extended import extend_farm

__all__ = ["parse_config", "load_config"]


def parse_config(data: dict, source: str | None = None) -> Farm:
    """The :class:`Farm` a parsed TOML document describes, its range-extended
    turbines split into delay taps; every problem in one :class:`ConfigError`."""
    farm = validate_config(data, source)
    try:
        return extend_farm(farm)
    except ConfigError as error:
        raise ConfigError(error.problems, source) from None


def load_config(path) -> Farm:
    """Read, validate and extend a TOML config file (:func:`parse_config`)."""
    return parse_config(read_config_file(path), str(Path(path)))
