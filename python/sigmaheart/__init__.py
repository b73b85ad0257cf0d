"""sigmaheart from Python: cardiac model personalisation (docs/python.md).

    import sigmaheart as sh
    cfg = sh.load_config("configs/sphere.yaml", overrides=["sigma0=1.2e5"])
    beat = cfg.run({"R_p": 1.5e8})            # curves and indices, numpy, SI, with units
    res = sh.sensitivity("study.yaml", output="out.h5", threads=2)
    data = sh.read_results(res)               # the results file as nested dicts of numpy arrays

Numbers are SI; every array comes with its unit (beat["units"], beat["index_units"], the `units`
attributes of a results file). Bad input raises InputError whose message is the command line's
(file:line:column: what was expected); a run that fails raises RunFailed (its results file, when
written, is RunFailed.results).
"""
import os

from ._core import Config, InputError, RunFailed, load_config, run_command

__all__ = ["Config", "InputError", "RunFailed", "load_config", "run_command", "calibrate",
           "personalize", "sensitivity", "specificity", "read_results", "Group", "Units"]


class Units(dict):
    """name -> unit string of the arrays next to it."""


def _study(command, config, overrides=(), output=None, threads=None, summary=None, resume=False):
    """Runs `sigmaheart COMMAND CONFIG` in this process; returns the results file's path."""
    config = os.fspath(config)
    args = [command, config]
    if output is None:
        stem = os.path.splitext(os.path.basename(config))[0]
        output = os.path.join("results", stem + "-" + command + ".h5")
    args += ["-o", os.fspath(output)]
    if summary is not None:
        args += ["--summary", os.fspath(summary)]
    if threads is not None:
        args += ["--threads", str(int(threads))]
    if resume:
        args.append("--resume")
    for o in overrides:
        args += ["--set", o]
    code, out, err = run_command(args)
    if code == 2:
        raise InputError(_first_error(err))
    if code != 0:
        e = RunFailed(err.strip() or out.strip() or "%s failed with exit code %d" % (command, code))
        e.results = os.fspath(output) if os.path.exists(output) else None
        e.exit_code = code
        raise e
    return os.fspath(output)


def _first_error(err):
    for line in err.splitlines():
        if line.startswith("error: "):
            return line[len("error: "):]
    return err.strip()


def calibrate(config, overrides=(), output=None, threads=None, summary=None, resume=False):
    """UT calibration of the config's global parameters (`sigmaheart calibrate`)."""
    return _study("calibrate", config, overrides, output, threads, summary, resume)


def personalize(config, overrides=(), output=None, threads=None, summary=None, resume=False):
    """ROUKF regional personalisation (`sigmaheart personalize`)."""
    return _study("personalize", config, overrides, output, threads, summary, resume)


def sensitivity(config, overrides=(), output=None, threads=None, summary=None, resume=False):
    """OAT / Morris / Sobol' study (`sigmaheart sensitivity`)."""
    return _study("sensitivity", config, overrides, output, threads, summary, resume)


def specificity(config, overrides=(), output=None, threads=None, summary=None, resume=False):
    """Specificity study (`sigmaheart specificity`)."""
    return _study("specificity", config, overrides, output, threads, summary, resume)


# `therapy` joins the commands above, one line, when the command exists (issue 44).


class Group(dict):
    """A group of a results file: name -> Group (subgroups) or numpy array / number / str
    (datasets); .attrs holds the group's attributes, .units the `units` attribute of each
    dataset that has one."""

    def __init__(self):
        super().__init__()
        self.attrs = {}
        self.units = Units()


def read_results(path):
    """A results file (HDF5) as nested Groups (dicts): datasets -> numpy arrays (scalars as
    numbers, strings as str), with each group's attributes in .attrs and the units of its
    datasets in .units."""
    import h5py
    import numpy as np

    def convert(value):
        if isinstance(value, bytes):
            return value.decode()
        if isinstance(value, np.ndarray) and value.dtype.kind in "SO":
            return [v.decode() if isinstance(v, bytes) else v for v in value.tolist()]
        return value

    def group(g):
        out = Group()
        out.attrs = {k: convert(v) for k, v in g.attrs.items()}
        for key, item in g.items():
            if isinstance(item, h5py.Group):
                out[key] = group(item)
            else:
                out[key] = convert(item[()])
                if "units" in item.attrs:
                    out.units[key] = convert(item.attrs["units"])
        return out

    with h5py.File(os.fspath(path), "r") as f:
        return group(f)
