"""One private virtual environment per peer tool, and the subprocess runner.

The published MGGP toolbox (PyPI ``mggp``) installs a top-level module named
``mggp`` that clashes with ours, and sysidentpy 0.9.0 caps numpy at 2.3.5
(below what our environment runs), so each peer lives in its own venv under
``benchmarks/.peers/<name>/`` (gitignored; ``MGGP_PEERS_DIR`` moves it) and is
driven by a small script run with that venv's python in isolated mode
(``python -I``: no PYTHONPATH, no script directory on sys.path, so our
``mggp``/``narx`` can never be imported there).

Typical use::

    from benchmarks.peers.envs import ensure_env, run_driver
    env = ensure_env("toolbox")      # creates it once (pip, network), then ~1 ms
    if not env["available"]:
        print(env["reason"])         # 'unavailable: pip install failed: ...'
    res = run_driver("toolbox", {"op": "versions"}, {})

``ensure_env`` never raises for an environment that cannot be built: it
returns ``{"available": False, "reason": "unavailable: ..."}`` (set
``MGGP_PEERS_OFFLINE=1`` to never try pip, e.g. on a machine without
network). The first build takes about a minute (numpy, scipy, scikit-learn
wheels); versions are recorded in ``<venv>/peer-env.json``. A driver that
fails on a job raises :class:`PeerError` (that is a bug or a bad input, not a
missing peer).
"""
from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, Mapping, Optional

import numpy as np

__all__ = ["PEERS", "PeerError", "peers_dir", "ensure_env", "run_driver"]

_HERE = Path(__file__).resolve().parent

#: Pinned package sets. The toolbox (2020) declares only ``deap`` although it
#: imports scikit-learn (``sklearn.metrics.mean_squared_error``) and scipy; we
#: pin a numpy 1.x of its era (it refers to ``np.AxisError``, gone in numpy 2).
PEERS: Dict[str, dict] = {
    "toolbox": {
        "packages": ["mggp==1.0.0", "deap==1.4.4", "numpy==1.26.4",
                     "scipy==1.13.1", "scikit-learn==1.5.2"],
        "dists": ["mggp", "deap", "numpy", "scipy", "scikit-learn"],
        "probe": "import mggp, sklearn; mggp.mggpElement; mggp.mggpEvolver",
        "driver": "_toolbox_driver.py",
    },
    "sysidentpy": {
        "packages": ["sysidentpy==0.9.0", "numpy==2.3.5", "scipy==1.16.3",
                     "matplotlib==3.10.8"],
        "dists": ["sysidentpy", "numpy", "scipy", "matplotlib"],
        "probe": "import sysidentpy.model_structure_selection as m; m.FROLS",
        "driver": "_sysidentpy_driver.py",
    },
}

_STAMP = "peer-env.json"
_CACHE: Dict[str, dict] = {}


class PeerError(RuntimeError):
    """A peer driver failed on a job (not: the peer is unavailable)."""


def peers_dir() -> Path:
    """Root of the peer venvs: ``$MGGP_PEERS_DIR`` or ``benchmarks/.peers``."""
    return Path(os.environ.get("MGGP_PEERS_DIR") or (_HERE.parent / ".peers"))


def _venv_python(venv: Path) -> Path:
    return venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def _unavailable(name: str, reason: str) -> dict:
    return {"name": name, "available": False, "reason": f"unavailable: {reason}",
            "python": None, "versions": {}, "path": None}


def _tail(text: str, n: int = 3) -> str:
    lines = [ln.strip() for ln in (text or "").strip().splitlines() if ln.strip()]
    return " | ".join(lines[-n:]) or "(no output)"


def _read_stamp(venv: Path, spec: list) -> Optional[dict]:
    try:
        stamp = json.loads((venv / _STAMP).read_text())
    except (OSError, ValueError):
        return None
    if stamp.get("packages") != spec or not _venv_python(venv).exists():
        return None
    return stamp


def _clean_env() -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP",
                        "VIRTUAL_ENV", "PYTHONUSERBASE")}
    env["PIP_NO_INPUT"] = "1"
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    return env


def _run(cmd, timeout, **kw):
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True,
                          timeout=timeout, env=_clean_env(), **kw)


def _build(name: str, venv: Path, spec: list, timeout: float) -> dict:
    """Create the venv, install the pinned packages, probe, stamp."""
    info = PEERS[name]
    if venv.exists():
        shutil.rmtree(venv)
    venv.parent.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    r = _run([sys.executable, "-m", "venv", venv], timeout=300)
    if r.returncode != 0:
        return _unavailable(name, f"python -m venv failed: {_tail(r.stderr)}")
    py = _venv_python(venv)
    r = _run([py, "-m", "pip", "install", "--no-input", *spec], timeout=timeout)
    if r.returncode != 0:
        shutil.rmtree(venv, ignore_errors=True)
        return _unavailable(name, f"pip install failed: {_tail(r.stderr or r.stdout)}")
    r = _run([py, "-I", "-c", info["probe"]], timeout=300)
    if r.returncode != 0:
        shutil.rmtree(venv, ignore_errors=True)
        return _unavailable(name, f"installed but does not import: {_tail(r.stderr)}")
    code = ("import importlib.metadata as m, json, sys, platform; "
            f"d = {info['dists']!r}; "
            "v = {k: m.version(k) for k in d}; v['python'] = platform.python_version(); "
            "print(json.dumps(v))")
    r = _run([py, "-I", "-c", code], timeout=300)
    if r.returncode != 0:
        return _unavailable(name, f"cannot read versions: {_tail(r.stderr)}")
    versions = json.loads(r.stdout.strip().splitlines()[-1])
    stamp = {"name": name, "packages": spec, "versions": versions,
             "install_seconds": round(time.perf_counter() - t0, 1),
             "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
    (venv / _STAMP).write_text(json.dumps(stamp, indent=2))
    return stamp


def ensure_env(name: str, *, install: bool = True, reinstall: bool = False,
               timeout: float = 1800.0) -> dict:
    """Create (once) and describe the venv of peer ``name``.

    Returns ``{"name", "available", "reason", "python", "versions", "path"}``.
    Fast when the venv exists with the same pinned packages (reads a stamp
    file); rebuilds it when the pins changed or ``reinstall``. With
    ``install=False`` (or ``MGGP_PEERS_OFFLINE=1`` in the environment) a
    missing venv is reported unavailable without trying pip. A file lock
    serialises concurrent builds of the same peer.
    """
    if name not in PEERS:
        raise ValueError(f"unknown peer {name!r}; known: {sorted(PEERS)}")
    venv = peers_dir() / name
    key = f"{name}@{venv}"
    if not reinstall and key in _CACHE:
        return dict(_CACHE[key])
    spec = list(PEERS[name]["packages"])
    if os.environ.get("MGGP_PEERS_OFFLINE", "") not in ("", "0"):
        install = False
    stamp = None if reinstall else _read_stamp(venv, spec)
    if stamp is None:
        if not install:
            return _unavailable(name, f"no venv at {venv} and installing is off "
                                      "(install=False or MGGP_PEERS_OFFLINE)")
        try:
            venv.parent.mkdir(parents=True, exist_ok=True)
            with open(venv.parent / f".{name}.lock", "w") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)
                stamp = None if reinstall else _read_stamp(venv, spec)
                if stamp is None:
                    stamp = _build(name, venv, spec, timeout)
        except subprocess.TimeoutExpired as e:
            stamp = _unavailable(name, f"install timed out after {e.timeout:.0f} s")
        except OSError as e:
            stamp = _unavailable(name, f"{type(e).__name__}: {e}")
        if stamp.get("available") is False:
            return stamp
    out = {"name": name, "available": True, "reason": None,
           "python": str(_venv_python(venv)), "versions": stamp["versions"],
           "path": str(venv)}
    _CACHE[key] = out
    return dict(out)


def run_driver(name: str, job: dict, arrays: Mapping[str, np.ndarray], *,
               timeout: Optional[float] = None, env: Optional[dict] = None) -> dict:
    """Run one job in peer ``name``'s driver; returns its JSON result.

    ``arrays`` go to an ``.npz`` file whose path is passed as ``job["data"]``;
    arrays the driver sends back (predictions) are read from
    ``job["out"]`` and merged into the result. If the peer is unavailable the
    result is ``{"available": False, "reason": ..., "versions": {}}``.
    """
    env = env or ensure_env(name)
    if not env["available"]:
        return {"available": False, "reason": env["reason"], "versions": {}}
    driver = _HERE / PEERS[name]["driver"]
    with tempfile.TemporaryDirectory(prefix=f"peer-{name}-") as tmp:
        data, out = Path(tmp) / "data.npz", Path(tmp) / "out.npz"
        np.savez(data, **{k: np.asarray(v, dtype=float) for k, v in arrays.items()})
        job = dict(job, data=str(data), out=str(out))
        try:
            r = subprocess.run([env["python"], "-I", str(driver)], input=json.dumps(job),
                               capture_output=True, text=True, timeout=timeout,
                               cwd=tmp, env=_clean_env())
        except subprocess.TimeoutExpired as e:
            raise PeerError(f"{name} driver timed out after {e.timeout:.0f} s "
                            f"on op {job.get('op')!r}") from None
        lines = r.stdout.strip().splitlines()
        try:
            result = json.loads(lines[-1]) if lines else None
        except ValueError:
            result = None
        if r.returncode != 0 or not isinstance(result, dict) or not result.get("ok"):
            msg = result.get("error") if isinstance(result, dict) else None
            raise PeerError(f"{name} driver failed on op {job.get('op')!r} "
                            f"(exit {r.returncode}): {msg or _tail(r.stderr, 8)}")
        if out.exists():
            with np.load(out) as z:
                result.update({k: z[k] for k in z.files})
    result.pop("ok", None)
    result.update(available=True, reason=None, versions=env["versions"])
    return result
