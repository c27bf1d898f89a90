"""Studies from a YAML spec, for ``serial-dynamics sweep SPEC.yaml [--scheduler ADDRESS]
[--workers N] --out results.parquet`` (config/sweep_example.yaml, docs/scale.md).

A spec names its ``study`` and gives that study's keyword arguments by name (the
signature of ``monte_carlo`` or ``identify_recordings`` is the schema: a field it does
not know, or of the wrong kind, is refused naming the field, before any work starts);
``robot`` is a built-in robot's name or a URDF path.
"""
from __future__ import annotations

import inspect
import os
import sys

import yaml

from .identification import identify_recordings
from .robustness import monte_carlo

STUDIES = {"monte_carlo": monte_carlo, "identification": identify_recordings}
NOT_IN_SPEC = ("client", "progress", "workers", "waypoints")   # the command line's, or code's


def load(path):
    """The spec at ``path`` as (study function, its keyword arguments), checked."""
    if not os.path.isfile(path):
        raise ValueError(f"spec {path!r} not found; give a YAML file (config/sweep_example.yaml)")
    with open(path) as f:
        spec = yaml.safe_load(f)
    if not isinstance(spec, dict):
        raise ValueError(f"spec {path!r} must be a YAML mapping of fields (study: ..., ...)")
    return check(spec)


def fields(study):
    """{field: default (inspect.Parameter.empty when required)} of a study."""
    return {k: p.default for k, p in inspect.signature(STUDIES[study]).parameters.items()
            if k not in NOT_IN_SPEC}


def check(spec):
    """(study function, keyword arguments) of a spec mapping; ValueError naming a bad field."""
    spec = dict(spec)
    study = spec.pop("study", None)
    if study not in STUDIES:
        raise ValueError(f"spec field 'study' = {study!r}; give one of {list(STUDIES)}")
    known = fields(study)
    for key, value in spec.items():
        if key not in known:
            raise ValueError(f"spec field {key!r} is not a field of study {study!r}; its fields "
                             f"are {sorted(known)}")
        want = _kind(known[key]) if key != "robot" else (str, "a built-in robot's name or a "
                                                         "URDF path")
        if want is not None and not _fits(value, known[key] if key != "robot" else ""):
            raise ValueError(f"spec field {key!r} = {value!r}; give {want[1]}")
    missing = [k for k, d in known.items() if d is inspect.Parameter.empty and k not in spec
               and k != "robot"]
    if missing:
        raise ValueError(f"spec of study {study!r} needs the field {missing[0]!r}")
    spec["robot"] = _robot(spec.get("robot"))
    return STUDIES[study], spec


def _kind(default):
    if isinstance(default, bool):
        return bool, "true or false"
    if isinstance(default, int):
        return int, "a whole number"
    if isinstance(default, float):
        return float, "a number"
    if isinstance(default, str):
        return str, "a string"
    if isinstance(default, tuple):
        return tuple, f"a list of {len(default)} numbers"
    return None


def _number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _fits(value, default):
    if isinstance(default, bool):
        return isinstance(value, bool)
    if isinstance(default, int):
        return isinstance(value, int) and not isinstance(value, bool)
    if isinstance(default, float):
        return _number(value)
    if isinstance(default, str):
        return isinstance(value, str)
    if isinstance(default, tuple):
        return isinstance(value, (list, tuple)) and len(value) == len(default) and \
            all(_number(v) for v in value)
    return True


def _robot(name):
    import serial_dynamics as sd
    from ..builtin import BUILTIN
    if name is None:
        return sd.default_robot()
    if name in BUILTIN:
        return sd.builtin_robot(name)
    if not os.path.isfile(name):
        raise ValueError(f"spec field 'robot' = {name!r}: neither a built-in robot {BUILTIN} "
                         "nor a URDF file")
    return sd.load_urdf(name)


def command(args):
    """``serial-dynamics sweep``: check the spec, run it (local processes or the cluster at
    ``--scheduler``), write the table as Parquet."""
    study, kwargs = load(args.spec)          # a bad field stops here, before any work
    if not args.out.endswith(".parquet"):
        raise ValueError(f"--out {args.out!r}: give a .parquet file")
    progress = not args.quiet
    if args.scheduler:
        from distributed import Client
        with Client(args.scheduler, timeout=30) as client:
            client.wait_for_workers(1, timeout=120)
            table = study(**kwargs, client=client, progress=progress)
    else:
        table = study(**kwargs, workers=args.workers, progress=progress)
    table.to_parquet(args.out)
    failed = int((table["error"] != "").sum())
    print(f"wrote {args.out}: {len(table)} cases ({failed} failed)", file=sys.stdout)
    return 0
