"""Sweeps over seeds split into shards, the same as the CLI's ``smid check --shard K/M --json``
and ``smid reproduce paper --shard K/M --json``: shard K of M runs every M-th seed from the K-th,
and merging all shards gives, bit for bit, one machine's run of all the seeds (every trial
depends on its seed alone; the merge orders by seed). :mod:`smid.distributed` runs the shards
on a Dask cluster.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

from . import _native
from ._native import InvalidError

Shard = Optional[Tuple[int, int]]


def _shard(shard: Any) -> Shard:
    """``None`` or ``(K, M)`` with 1 <= K <= M (a list is taken as a pair)."""
    if shard is None:
        return None
    try:
        k, m = (int(v) for v in shard)
    except (TypeError, ValueError):
        raise InvalidError(f"invalid `shard`: {shard!r}: expected (K, M)") from None
    if not 1 <= k <= m:
        raise InvalidError(f"invalid `shard`: {k}/{m}: expected K/M with 1 <= K <= M")
    return (k, m)


def _count(v: Any, what: str, least: int) -> int:
    try:
        n = int(v)
    except (TypeError, ValueError):
        raise InvalidError(f"invalid `{what}`: {v!r}: expected an integer") from None
    if n < least:
        raise InvalidError(f"invalid `{what}`: {n}: expected at least {least}")
    return n


@dataclass(frozen=True)
class CheckResult:
    """A containment check (or the merge of its shards): counts of trials whose bounds held
    the truth, missed it (a bug: ``missed`` lists the seeds) or ended with no bound
    (``errors``: seed and message); ``text`` is the table ``smid check`` prints."""

    plugin: str
    method: str
    any_record: bool
    first_seed: int
    trials: int
    contained: int
    missed: List[int]
    errors: List[Tuple[int, str]]
    text: str
    raw: Dict[str, Any]


def _check_result(run: Dict[str, Any], text: str) -> CheckResult:
    s = run["summary"]
    return CheckResult(
        plugin=run["plugin"],
        method=run["method"],
        any_record=run["any_record"],
        first_seed=run["first_seed"],
        trials=s["trials"],
        contained=s["contained"],
        missed=list(s["missed"]),
        errors=[(int(a), str(b)) for a, b in s["errors"]],
        text=text,
        raw=run,
    )


def check_shard(
    plugin: str = "output_backlash",
    trials: int = 1000,
    *,
    shard: Shard = None,
    first_seed: int = 1,
    method: Optional[str] = None,
    any_record: bool = False,
    jobs: Optional[int] = None,
) -> str:
    """Run shard ``(K, M)`` of a containment check (all of it when ``None``) and return its
    JSON text, exactly what ``smid check --shard K/M --json`` writes."""
    return _native.check(plugin, _count(trials, "trials", 1), _count(first_seed, "first_seed", 0), method,
                         bool(any_record), _shard(shard), None if jobs is None else _count(jobs, "jobs", 1))


def check_merge(shards: Sequence[Union[str, Dict[str, Any]]]) -> CheckResult:
    """Merge the shards (JSON texts or dicts, any order) of one check into its table; refused
    (``smid.InvalidError``) when a shard belongs to another run, is given twice or is missing."""
    texts = [s if isinstance(s, str) else json.dumps(s) for s in shards]
    m = json.loads(_native.check_merge(texts))
    return _check_result(m["run"], m["text"])


def check(
    plugin: str = "output_backlash",
    trials: int = 1000,
    *,
    first_seed: int = 1,
    method: Optional[str] = None,
    any_record: bool = False,
    jobs: Optional[int] = None,
) -> CheckResult:
    """A whole containment check on this machine (``smid check``)."""
    run = json.loads(check_shard(plugin, trials, first_seed=first_seed, method=method, any_record=any_record, jobs=jobs))
    return _check_result(run, _native.format_check(json.dumps(run)))


def reproduce_shard(seeds: int = 20, *, shard: Shard = None) -> str:
    """Shard ``(K, M)`` of the paper's Tables I-II over seeds ``1..=seeds`` as JSON text
    (``smid reproduce paper --seeds S --shard K/M --json``)."""
    return _native.reproduce_shard(_count(seeds, "seeds", 1), _shard(shard))


def reproduce_merge(shards: Sequence[Union[str, Dict[str, Any]]]) -> Tuple[Dict[str, Any], str]:
    """Merge reproduction shards into ``(tables, text)``: the medians as a dict and Tables
    I-II as ``smid reproduce paper`` prints them."""
    texts = [s if isinstance(s, str) else json.dumps(s) for s in shards]
    m = json.loads(_native.reproduce_merge(texts))
    return m["tables"], m["text"]
