"""Evolution state and its JSON checkpoints (atomic write, safe load).

Typical use (``evolve`` does this itself with ``checkpoint=path``)::

    from mggp.gp.checkpoint import save_checkpoint, load_checkpoint
    save_checkpoint("run.ckpt.json", state)        # state: EvolutionState
    state = load_checkpoint("run.ckpt.json", pset)

The file is plain JSON: genes are lists of node names rebuilt with
:func:`mggp.gp.primitives.tree_from_tokens` (no ``eval``, no pickle); the
random generator state is ``random.Random.getstate()`` as lists; floats are
written with ``repr`` precision (exact round trip) and non-finite values as
the strings ``"inf"``, ``"-inf"``, ``"nan"``. Writing goes to a temporary
file in the same folder, is fsync'ed and then renamed over the target with
``os.replace``, so a crash leaves either the old or the new checkpoint.
:class:`CheckpointWriter` spaces the writes of a run so that they take at
most :data:`CHECKPOINT_SHARE` (5 %) of its wall time, and encodes only the
fitness-cache entries added since its previous write.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import random
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

from deap import tools

from ..exceptions import CheckpointError
from .individual import Individual, ParetoArchive, ParetoRow
from .primitives import Decoder, tree_from_tokens, tree_to_tokens

__all__ = ["EvolutionState", "save_checkpoint", "load_checkpoint", "CheckpointWriter",
           "CachePacker", "CHECKPOINT_SHARE",
           "settings_fingerprint", "data_digest", "checkpoint_seed", "checkpoint_settings",
           "checkpoint_search", "copy_checkpoint", "pilot_checkpoint", "pilot_checkpoints",
           "FORMAT", "VERSION"]

FORMAT = "mggp-checkpoint"
VERSION = 1

#: share of a run's wall time its periodic checkpoints may take (half of the 10 %
#: they must stay under, leaving room for the last write and for timing noise)
CHECKPOINT_SHARE = 0.05


def pset_signature(pset) -> List[List[str]]:
    """Neutral description of a set (names and types), for fingerprints."""
    rows = []
    for kind, table in (("prim", pset.primitives), ("term", pset.terminals)):
        for t in sorted(table, key=lambda c: c.__name__):
            for node in table[t]:
                args = ",".join(a.__name__ for a in getattr(node, "args", ()))
                rows.append([kind, t.__name__, node.name, args])
    return rows


@dataclass
class EvolutionState:
    """Everything the generational loop needs to continue.

    Attributes
    ----------
    generation : int
        Last completed generation (0: initial population evaluated).
    rng : random.Random
    population : list of Individual
        All evaluated.
    logbook : deap.tools.Logbook
    archive : ParetoArchive
    cache : dict
        Sorted tuple of term texts -> fitness (pure-function cache).
    evaluations : int
        Structures sent to ``evaluate_batch`` so far.
    settings : dict
        The run's settings (JSON-able).
    fingerprint : str
        Hash of the settings that must match to resume (all but
        ``generations``) and of the primitive set.
    """

    generation: int
    rng: random.Random
    population: List[Individual]
    logbook: tools.Logbook
    archive: ParetoArchive
    cache: Dict[Tuple[str, ...], float]
    evaluations: int
    settings: Dict[str, Any] = field(default_factory=dict)
    fingerprint: str = ""


def settings_fingerprint(settings: Dict[str, Any], pset) -> str:
    """SHA-256 of the settings (except ``generations``) and the set."""
    s = {k: v for k, v in settings.items() if k != "generations"}
    blob = json.dumps({"settings": s, "pset": pset_signature(pset)},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


def data_digest(data) -> str:
    """SHA-256 of a record's samples and signal names (a checkpoint belongs
    to the data it was scored on)."""
    h = hashlib.sha256()
    h.update(json.dumps([data.output, list(data.inputs)]).encode())
    h.update(data.U.tobytes())
    if data.y is not None:
        h.update(data.y.tobytes())
    return h.hexdigest()


def checkpoint_settings(path) -> dict:
    """The ``settings`` stored in the checkpoint at ``path`` as written, not
    validated ({} if there is no readable file or no settings)."""
    try:
        with open(path, encoding="utf-8") as fh:
            st = json.load(fh).get("settings")
    except (OSError, ValueError, AttributeError, RecursionError):
        return {}
    return st if isinstance(st, dict) else {}


def checkpoint_search(path) -> Optional[str]:
    """The search a checkpoint of a fit with pilots belongs to (the model
    class and whether the constant is offered: ``context['search']``), None
    when there is no file or no such entry."""
    ctx = checkpoint_settings(path).get("context")
    tag = ctx.get("search") if isinstance(ctx, dict) else None
    return tag if isinstance(tag, str) else None


def pilot_checkpoint(path, key: str) -> str:
    """Where a fit checkpointed at ``path`` keeps the checkpoint of its pilot
    ``key`` (a model class, e.g. 'no_phi', or 'no_phi-no-constant'):
    beside it, ``PATH.pilot-KEY``."""
    return f"{os.fspath(path)}.pilot-{key}"


def pilot_checkpoints(path) -> List[str]:
    """The pilot checkpoints beside ``path`` (:func:`pilot_checkpoint`)."""
    import glob
    return sorted(glob.glob(glob.escape(os.fspath(path)) + ".pilot-*"))


def copy_checkpoint(src, dst) -> None:
    """Copy the checkpoint ``src`` to ``dst`` atomically (a crash leaves
    ``dst`` as it was or the whole copy)."""
    from narx.atomic import atomic_write_text
    with open(src, encoding="utf-8") as fh:
        atomic_write_text(dst, fh.read())


def checkpoint_seed(path) -> Optional[int]:
    """The seed stored in the checkpoint at ``path`` (None if there is no
    file or no integer seed), so a run started without a seed can resume."""
    seed = checkpoint_settings(path).get("seed")
    return seed if isinstance(seed, int) and not isinstance(seed, bool) else None


def _num(x) -> Any:
    x = float(x)
    if math.isfinite(x):
        return x
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def _unnum(v) -> float:
    if isinstance(v, str) and v in ("inf", "-inf", "nan"):
        return float(v)
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return float(v)
    raise ValueError(f"not a number: {v!r}")


def _jsonable(v):
    if isinstance(v, float):
        return _num(v)
    return v


class CachePacker:
    """The fitness cache in its packed JSON form, encoded incrementally.

    Packed form: ``terms`` (the distinct term texts, each written once) and
    ``entries`` ``[[index, ...], fitness]`` (a run scores tens of thousands
    of structures that share a few hundred terms). The cache of a run only
    grows (a structure is scored once), so each :meth:`text` encodes only
    the entries added since the previous one; a cache that is another
    object or has shrunk is encoded anew.
    """

    def __init__(self):
        self._reset(None)

    def _reset(self, cache):
        self.source, self.done = cache, 0
        self.index: Dict[str, int] = {}
        self.entries: List[str] = []

    def text(self, cache: Dict[Tuple[str, ...], float]) -> str:
        """JSON text of the packed cache."""
        if cache is not self.source or len(cache) < self.done:
            self._reset(cache)
        index = self.index
        for key, v in itertools.islice(cache.items(), self.done, None):
            ids = ",".join(str(index.setdefault(t, len(index))) for t in key)
            self.entries.append(f"[[{ids}],{json.dumps(_num(v), allow_nan=False)}]")
        self.done = len(cache)
        return ('{"terms":' + json.dumps(list(index), separators=(",", ":"))
                + ',"entries":[' + ",".join(self.entries) + "]}")


def _pack_cache(cache: Dict[Tuple[str, ...], float]) -> dict:
    """The fitness cache in packed form (see :class:`CachePacker`)."""
    return json.loads(CachePacker().text(cache))


def _unpack_cache(packed) -> Dict[Tuple[str, ...], float]:
    """Inverse of :func:`_pack_cache`; also reads the older plain list
    ``[[[term, ...], fitness], ...]``."""
    if isinstance(packed, list):                 # written before the packed form
        packed = {"terms": [], "entries": packed}
    if not (isinstance(packed, dict) and isinstance(packed.get("terms"), list)
            and isinstance(packed.get("entries"), list)
            and all(isinstance(t, str) for t in packed["terms"])):
        raise ValueError("'fitness_cache' must be {'terms': [text, ...], 'entries': [...]}")
    terms = packed["terms"]
    cache = {}
    for i, entry in enumerate(packed["entries"]):
        ok = isinstance(entry, list) and len(entry) == 2 and isinstance(entry[0], list)
        key = None
        if ok and all(isinstance(t, str) for t in entry[0]):
            key = tuple(entry[0])
        elif ok and all(isinstance(t, int) and not isinstance(t, bool)
                        and 0 <= t < len(terms) for t in entry[0]):
            key = tuple(terms[t] for t in entry[0])
        if key is None:
            raise ValueError(f"fitness_cache entry {i} must be [[term index, ...], fitness]")
        cache[key] = _unnum(entry[1])
    return cache


def save_checkpoint(path, state: EvolutionState,
                    packer: Optional[CachePacker] = None) -> None:
    """Write ``state`` to ``path`` atomically (temp file, fsync, replace).

    Parameters
    ----------
    path : str or os.PathLike
    state : EvolutionState
    packer : CachePacker, optional
        Kept across the saves of one run, it encodes only the fitness-cache
        entries added since the previous save (the cache is most of the
        file); the file is the same with or without it.
    """
    path = os.fspath(path)
    version, internal, gauss = state.rng.getstate()
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "generation": state.generation,
        "settings": state.settings,
        "fingerprint": state.fingerprint,
        "rng_state": [version, list(internal), gauss],
        "population": [{"genes": [tree_to_tokens(g) for g in ind],
                        "fitness": _num(ind.fitness.values[0])}
                       for ind in state.population],
        "logbook": {"header": list(state.logbook.header or []),
                    "records": [{k: _jsonable(v) for k, v in r.items()}
                                for r in state.logbook]},
        "pareto": [{"complexity": r.complexity, "fitness": _num(r.fitness),
                    "genes": [list(g) for g in r.genes]}
                   for r in state.archive.best_per_complexity()],
        "evaluations": state.evaluations,
    }
    text = json.dumps(doc, allow_nan=False, separators=(",", ":"))
    text = (text[:-1] + ',"fitness_cache":' + (packer or CachePacker()).text(state.cache)
            + "}")
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".ckpt-", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    try:  # make the rename durable too (best effort, POSIX only)
        dfd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass


class CheckpointWriter:
    """Writes the checkpoints of one run within a share of its wall time.

    A call writes the state when ``force`` is true, on the first call, or
    when the time since the end of the previous write is at least that
    write's duration divided by ``share``: the periodic writes then take at
    most ``share`` of the run's wall time, however large the state grows
    (the fitness cache grows with every generation). A run killed between
    two writes resumes from the last one and, its random state being in
    the file, still ends as an uninterrupted run does.

    Parameters
    ----------
    path : str or os.PathLike
    share : float
        In (0, 1]; 1 writes on every call.
    clock : callable
        Seconds, monotonic (``time.perf_counter``).
    """

    def __init__(self, path, share: float = CHECKPOINT_SHARE, clock=time.perf_counter):
        if not 0 < share <= 1:
            raise ValueError(f"share must be in (0, 1], got {share!r}")
        self.path, self.share, self.clock = path, share, clock
        self.packer = CachePacker()
        self.written = 0
        self._end: Optional[float] = None
        self._cost = 0.0

    def __call__(self, state: EvolutionState, force: bool = False) -> bool:
        """Write ``state`` if due (or ``force``); returns whether it did."""
        start = self.clock()
        if (not force and self._end is not None and self.share < 1
                and start - self._end < self._cost / self.share):
            return False
        save_checkpoint(self.path, state, self.packer)
        self._end = self.clock()
        self._cost = self._end - start
        self.written += 1
        return True


def _rebuild_individual(genes, fitness, pset, where):
    if not isinstance(genes, list) or not genes:
        raise ValueError(f"{where}: 'genes' must be a non-empty list")
    trees = []
    for gi, tokens in enumerate(genes):
        if not isinstance(tokens, list):
            raise ValueError(f"{where}, gene {gi}: node names must be a list")
        try:
            trees.append(tree_from_tokens(tokens, pset))
        except ValueError as exc:
            raise ValueError(f"{where}, gene {gi}: {exc}") from None
    ind = Individual(trees)
    if fitness is not None:
        ind.fitness.values = (_unnum(fitness),)
    return ind


def _consistent(gen, population, logbook, settings, fingerprint, pset) -> None:
    """The content agrees with the settings it was written under (an edited
    or truncated file is refused rather than resumed)."""
    if settings_fingerprint(settings, pset) != fingerprint:
        raise ValueError("'fingerprint' does not match the stored settings and "
                         "primitive set (edited, or written for another primitive set)")
    size = settings.get("population_size")
    if size is not None and len(population) != size:
        raise ValueError(f"'population' holds {len(population)} individuals, the "
                         f"settings say population_size={size}")
    if len(logbook) != gen + 1:
        raise ValueError(f"'generation' is {gen} but the logbook holds {len(logbook)} "
                         f"generation(s)")
    mt, mh = settings.get("max_terms"), settings.get("max_height")
    for i, ind in enumerate(population):
        if mt is not None and len(ind) > mt:
            raise ValueError(f"population[{i}] has {len(ind)} genes, more than "
                             f"max_terms={mt}")
        if mh is not None and any(t.height > mh for t in ind):
            raise ValueError(f"population[{i}] has a gene higher than max_height={mh}")


def load_checkpoint(path, pset, decoder: Optional[Decoder] = None) -> EvolutionState:
    """Read and validate a checkpoint written by :func:`save_checkpoint`.

    Parameters
    ----------
    path : str or os.PathLike
    pset : deap.gp.PrimitiveSetTyped
        The set of the run; genes are rebuilt from node names in it.
    decoder : Decoder, optional
        Used to decode the archived models.

    Returns
    -------
    EvolutionState

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    ValueError
        ``"checkpoint PATH: PROBLEM"`` for unreadable JSON, another format
        or version, missing or malformed fields, or genes not valid in
        ``pset``.
    """
    path = os.fspath(path)
    decoder = decoder if decoder is not None else Decoder(getattr(pset, "signals", None))

    def fail(msg):
        return CheckpointError(f"checkpoint {path}: {msg}")

    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except FileNotFoundError:
        raise
    except (OSError, ValueError, RecursionError) as exc:   # JSON, UTF-8, nesting
        raise fail(f"not a readable JSON file ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise fail(f"not an mggp checkpoint (missing format {FORMAT!r})")
    if doc.get("version") != VERSION:
        raise fail(f"unsupported version {doc.get('version')!r} (expected {VERSION})")
    need = ("generation", "settings", "fingerprint", "rng_state", "population",
            "logbook", "pareto", "fitness_cache", "evaluations")
    missing = [k for k in need if k not in doc]
    if missing:
        raise fail(f"missing field(s) {', '.join(missing)}")
    try:
        gen = doc["generation"]
        if not isinstance(gen, int) or isinstance(gen, bool) or gen < 0:
            raise ValueError(f"'generation' must be an integer >= 0, got {gen!r}")
        rs = doc["rng_state"]
        if not (isinstance(rs, list) and len(rs) == 3 and isinstance(rs[1], list)
                and all(isinstance(x, int) for x in rs[1])):
            raise ValueError("'rng_state' is not a random.Random state")
        rng = random.Random()
        try:
            rng.setstate((rs[0], tuple(rs[1]), rs[2]))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"'rng_state' is not a random.Random state ({exc})") from None
        pop = doc["population"]
        if not isinstance(pop, list) or not pop:
            raise ValueError("'population' must be a non-empty list")
        population = []
        for i, item in enumerate(pop):
            if not isinstance(item, dict) or "genes" not in item or "fitness" not in item:
                raise ValueError(f"population[{i}] needs 'genes' and 'fitness'")
            population.append(_rebuild_individual(item["genes"], item["fitness"],
                                                  pset, f"population[{i}]"))
        lb = doc["logbook"]
        logbook = tools.Logbook()
        logbook.header = list(lb.get("header") or [])
        for r in lb.get("records", []):
            logbook.record(**{k: (_unnum(v) if isinstance(v, str) else v)
                              for k, v in r.items()})
        archive = ParetoArchive()
        rows = []
        for i, r in enumerate(doc["pareto"]):
            ind = _rebuild_individual(r["genes"], None, pset, f"pareto[{i}]")
            terms = decoder.decode_individual(ind)
            if len(terms) != r["complexity"]:
                raise ValueError(f"pareto[{i}]: complexity {r['complexity']} does "
                                 f"not match its {len(terms)} distinct terms")
            rows.append(ParetoRow(len(terms), _unnum(r["fitness"]), terms,
                                  tuple(tuple(g) for g in r["genes"])))
        archive.restore(rows)
        cache = _unpack_cache(doc["fitness_cache"])
        evaluations = doc["evaluations"]
        if not isinstance(evaluations, int) or evaluations < 0:
            raise ValueError(f"'evaluations' must be an integer >= 0, got {evaluations!r}")
        settings = doc["settings"]
        if not isinstance(settings, dict):
            raise ValueError("'settings' must be an object")
        _consistent(gen, population, logbook, settings, str(doc["fingerprint"]), pset)
    except (KeyError, TypeError, AttributeError) as exc:
        raise fail(f"malformed content ({type(exc).__name__}: {exc})") from None
    except ValueError as exc:
        raise fail(str(exc)) from None
    return EvolutionState(gen, rng, population, logbook, archive, cache,
                          evaluations, settings, str(doc["fingerprint"]))
