"""Sweeps on a Dask cluster: the shards of a containment check or of the paper reproduction
run as Dask tasks (one shard per task, on any worker of a local or remote cluster) and merge
into the table one machine computes for the same seeds, bit for bit.

Dask, not Ray: the shards are independent pure functions of their seeds, which is exactly a
Dask ``client.map``; ``dask[distributed]`` is a pure-Python pip install that starts a local
cluster in a second (``LocalCluster``) and scales to clusters through the same ``Client``
(``dask-scheduler`` / ``dask-worker``, dask-jobqueue for SLURM/PBS, dask-kubernetes). Ray would
bring a large binary runtime and its own object store for no gain here.

Laptop::

    from smid.distributed import check
    r = check("output_backlash", 10_000, shards=40)        # a LocalCluster of this machine

Cluster::

    from dask.distributed import Client
    r = check("output_backlash", 10_000, shards=400, client=Client("tcp://scheduler:8786"))

Every worker needs the ``smid`` package of the same commit (``pip install .``): the merge
refuses shards of another run (plugin, method, seeds, shard count) and missing or extra
shards, but it cannot tell two builds apart.
"""
from __future__ import annotations

from typing import Any, List, Optional, Tuple

from . import sweeps
from ._native import InvalidError


def _run_shards(fn, shards: int, client: Any, workers: Optional[int], **kwargs) -> List[str]:
    """Run ``fn(shard=(k, shards), **kwargs)`` for every k as Dask tasks on ``client``, or on a
    new local cluster of ``workers`` processes (closed afterwards, whatever happens)."""
    if int(shards) < 1:
        raise InvalidError("invalid `shards`: must be at least 1")
    shards = int(shards)

    def run(c: Any) -> List[str]:
        futures = c.map(lambda k: fn(shard=(k, shards), **kwargs), range(1, shards + 1), pure=False)
        return c.gather(futures)

    if client is not None:
        if workers is not None:
            raise InvalidError("invalid `workers`: give either a client or the size of a new local cluster")
        return run(client)
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("smid.distributed needs Dask: pip install 'dask[distributed]'") from e
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        with Client(cluster) as c:
            return run(c)


def check(
    plugin: str = "output_backlash",
    trials: int = 1000,
    *,
    shards: int = 8,
    client: Any = None,
    workers: Optional[int] = None,
    first_seed: int = 1,
    method: Optional[str] = None,
    any_record: bool = False,
) -> sweeps.CheckResult:
    """A containment check split into ``shards`` Dask tasks (each runs its seeds on one
    thread) on ``client``, or on a new local cluster of ``workers`` processes; merged into the
    one-machine table."""
    parts = _run_shards(
        sweeps.check_shard,
        shards,
        client,
        workers,
        plugin=plugin,
        trials=trials,
        first_seed=first_seed,
        method=method,
        any_record=any_record,
        jobs=1,
    )
    return sweeps.check_merge(parts)


def reproduce(seeds: int = 20, *, shards: int = 4, client: Any = None, workers: Optional[int] = None) -> Tuple[dict, str]:
    """The paper's Tables I-II over ``seeds`` seeds, split into ``shards`` Dask tasks."""
    parts = _run_shards(sweeps.reproduce_shard, shards, client, workers, seeds=seeds)
    return sweeps.reproduce_merge(parts)


def main(argv: Optional[List[str]] = None) -> int:
    """``python -m smid.distributed check|reproduce ...``: the CLI's sweeps on a Dask cluster
    (a local one, or ``--scheduler tcp://host:8786``); prints the same table as ``smid check``
    / ``smid reproduce paper``; exit code 1 when a trial missed the truth."""
    import argparse
    import json

    p = argparse.ArgumentParser(prog="python -m smid.distributed", description=main.__doc__)
    sub = p.add_subparsers(dest="what", required=True)
    c = sub.add_parser("check", help="containment check (smid check)")
    c.add_argument("--plugin", default="output_backlash")
    c.add_argument("--trials", type=int, default=1000)
    c.add_argument("--first-seed", type=int, default=1)
    c.add_argument("--method", default=None)
    c.add_argument("--any-record", action="store_true")
    r = sub.add_parser("reproduce", help="the paper's Tables I-II (smid reproduce paper)")
    r.add_argument("--seeds", type=int, default=20)
    for q in (c, r):
        q.add_argument("--shards", type=int, default=8, help="Dask tasks (shards of the seeds)")
        q.add_argument("--workers", type=int, default=None, help="local cluster size (default: cores)")
        q.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
        q.add_argument("--json", default=None, help="also write the merged result as JSON")
    a = p.parse_args(argv)
    if a.scheduler:
        from dask.distributed import Client

        with Client(a.scheduler) as client:
            return _main(a, client)
    return _main(a, None)


def _main(a: Any, client: Any) -> int:
    import json

    if a.what == "check":
        res = check(a.plugin, a.trials, shards=a.shards, client=client, workers=None if client else a.workers,
                    first_seed=a.first_seed, method=a.method, any_record=a.any_record)
        print(res.text, end="")
        if a.json:
            with open(a.json, "w") as f:
                json.dump(res.raw, f, indent=2)
        return 1 if res.missed else 0
    tables, text = reproduce(a.seeds, shards=a.shards, client=client, workers=None if client else a.workers)
    print(text, end="")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(tables, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
