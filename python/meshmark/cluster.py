# SPDX-License-Identifier: MIT
"""Catalogue work on a Dask cluster (docs/cluster.md).

    from dask.distributed import Client
    import meshmark
    client = Client("tcp://127.0.0.1:8786")
    catalog = meshmark.Catalog("shop.catalog", create=True)
    report = catalog.add(["models/"], "published/", client=client)   # as `catalog add --json`
    found = catalog.scan(["suspects/a.glb"], client=client)          # as `catalog scan --json`

catalog_add: this process (the coordinator) plans, the workers mark (each task a function of
the original's bytes, its asset, its seed or recorded key and the parameters, named by them:
run twice, it makes the same bytes), and this process alone records each marked asset in the
catalogue and writes its files, the key durable before the copy is visible. A worker lost
midway: its tasks run again elsewhere. This process lost: running the same call again
finishes the batch. With a seed, the copies and keys are those of a local `catalog add`, byte
for byte.

catalog_issue: every new name is recorded here first, with its code; the workers make the
copies in chunks (each building the asset's basis once), and this process writes them and
records them delivered: the codes and bytes of a local issue.

catalog_scan: the suspects, in chunks, are read on the workers, each opening the catalogue
read-only (a file every worker reaches at the same path, or PostgreSQL: a password in the
location is not sent, give it to the workers as PGPASSWORD or ~/.pgpass).

Workers need this package importable (pip install it on each) and the originals (add) or
suspects (scan) at the same paths as here. `meshmark catalog add|issue|scan --scheduler ADDRESS`
runs these functions (python3 -m meshmark.cluster, reading its request from a file).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ALL_COMPLETED, FIRST_COMPLETED, ThreadPoolExecutor, wait
from typing import Any

from . import _meshmark

Location = str | os.PathLike[str]


def _mark(tasks: list[str]) -> list[tuple[str, list[tuple[str, bytes]]]]:
    """A worker's task: a few assets marked in memory, one after the other (_catalog_mark)."""
    from meshmark import _meshmark as core  # on the worker

    return [core._catalog_mark(task, 1) for task in tasks]


def _scan(location: str, suspects: list[str], options: dict[str, Any]) -> dict[str, Any]:
    """A worker's task: a chunk of suspects scanned against the catalogue at location."""
    from meshmark import _meshmark as core  # on the worker

    catalog = core.Catalog(location, lock_timeout=options.pop("lock_timeout"))
    return catalog.scan(suspects, **options)


def _slots(client: Any) -> int:
    """Tasks to keep in flight: twice the workers' threads (at least 4)."""
    try:
        threads = int(sum(client.nthreads().values()))
    except Exception:  # noqa: BLE001 - a client of another kind: a fixed window
        threads = 2
    return max(4, 2 * threads)


def _open(catalog: Any, create: bool) -> _meshmark.Catalog:
    if isinstance(catalog, _meshmark.Catalog):
        return catalog
    return _meshmark.Catalog(catalog, create=create)


def catalog_add(
    catalog: _meshmark.Catalog | Location,
    inputs: Sequence[Location],
    output: Location,
    *,
    client: Any,
    seed: int | None = None,
    strength: float | None = None,
    message: str | None = None,
    basis_size: int = 100,
    coefficients: int = 8,
    force: bool = False,
    retries: int = 2,
    batch: int | None = None,
    recorders: int = 4,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """`catalog add` with the marking on the client's workers; its --json report.

    batch: files per Dask task (default: up to 4, fewer when there are few files to spread over
    the workers); a task's cost to the scheduler and the workers is shared by its files.
    recorders: threads recording results at once (each record waits mostly on the disk: its
    transactions and the copy's atomic writes; the catalogue serializes its own transactions).
    retries: times a task whose worker failed (not the file: that is its outcome) is run again
    elsewhere; a worker that dies is handled by Dask itself (its tasks rescheduled).
    progress(done, total) is called as files are recorded.
    """
    from dask.distributed import as_completed

    opened = _open(catalog, create=True)
    outcomes, tasks = _meshmark._catalog_plan_add(
        opened,
        [os.fspath(p) for p in inputs],
        os.fspath(output),
        seed=seed,
        strength=strength,
        message=message,
        basis_size=basis_size,
        coefficients=coefficients,
        force=force,
    )
    total = len(outcomes)
    done = total - len(tasks)
    if progress:
        progress(done, total)
    slots = _slots(client)
    if batch is None:
        batch = max(1, min(4, len(tasks) // (2 * slots)))
    if batch < 1:
        raise _meshmark.InvalidOption("batch must be >= 1.")
    # A batch's Dask key: its tasks' names (each a function of its content), hashed.
    batches = [tasks[i : i + batch] for i in range(0, len(tasks), batch)]
    pending = iter(batches)
    running: dict[Any, list[tuple[str, str]]] = {}

    def submit_next() -> Any | None:
        group = next(pending, None)
        if group is None:
            return None
        names = "+".join(name for _, name in group)
        key = group[0][1] if len(group) == 1 else f"meshmark-add-batch-{_digest(names)}"
        future = client.submit(
            _mark, [text for text, _ in group], key=key, pure=False, retries=retries
        )
        running[future] = group
        return future

    def record(text: str, result: Any) -> tuple[int, str]:
        index = json.loads(text)["file"]
        if isinstance(result, Exception):
            return index, _cluster_failure(text, result)
        marked, files = result
        return index, _meshmark._catalog_record(opened, text, marked, files)

    if recorders < 1:
        raise _meshmark.InvalidOption("recorders must be >= 1.")
    window = as_completed(loop=client.loop)  # type: ignore[no-untyped-call]  # (this client's)
    for _ in range(slots):
        future = submit_next()
        if future is None:
            break
        window.add(future)  # type: ignore[no-untyped-call]
    recording: set[Any] = set()
    with ThreadPoolExecutor(max_workers=recorders) as pool:

        def collect(block: bool) -> None:
            nonlocal done
            finished, _ = wait(recording, return_when=FIRST_COMPLETED if block else ALL_COMPLETED)
            for job in finished:
                recording.discard(job)
                index, outcome = job.result()
                outcomes[index] = outcome
                done += 1
                if progress:
                    progress(done, total)

        for future in window:
            group = running.pop(future)
            try:
                results = future.result()
            except Exception as error:  # noqa: BLE001 - the cluster's failure: these files' outcome
                results = [error] * len(group)
            future.release()
            for (text, _), result in zip(group, results):
                recording.add(pool.submit(record, text, result))
            # Results wait here (their bytes in memory) for at most two rounds of recorders.
            while len(recording) > 2 * recorders:
                collect(block=True)
            following = submit_next()
            if following is not None:
                window.add(following)  # type: ignore[no-untyped-call]
        collect(block=False)
    return _meshmark._catalog_add_report(opened, outcomes)


def _digest(text: str) -> str:
    import hashlib

    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _cluster_failure(text: str, error: Exception) -> str:
    """The outcome of a file whose task the cluster gave up on."""
    task = json.loads(text)
    return json.dumps(
        {
            "path": task["input"],
            "asset": task["asset"],
            "outcome": "failed",
            "reason": f"{task['input']}: the cluster could not mark it "
            f"({type(error).__name__}: {error}); run the add again.",
            "vertices": 0,
            "seconds": 0.0,
        }
    )


def _make_copies(task: str) -> tuple[str, list[tuple[str, bytes]]]:
    """A worker's task: some recipients' copies made in memory (_meshmark._catalog_make_copies)."""
    from meshmark import _meshmark as core  # on the worker

    return core._catalog_make_copies(task, 1)


def catalog_issue(
    catalog: _meshmark.Catalog | Location,
    asset: str,
    recipients: Sequence[str],
    output_pattern: str,
    *,
    client: Any,
    recipients_file: Location | None = None,
    lock_timeout: float = 60.0,
    per_task: int | None = None,
    retries: int = 2,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """`catalog issue` with the copies made on the client's workers; its --json report.

    Every new name is recorded here with its code before any task starts; each task (per_task
    copies, default: spread over twice the workers' threads, at least 8) builds the asset's
    basis once and makes its copies; this process writes them and records them delivered.
    """
    import time

    from dask.distributed import as_completed

    start = time.monotonic()
    opened = _open(catalog, create=False)
    names = list(recipients)
    if recipients_file is not None:
        names_in_file = os.fspath(recipients_file)
    else:
        names_in_file = None
    if per_task is None:
        per_task = max(8, -(-max(1, len(names)) // _slots(client)))
    plan, tasks = _meshmark._catalog_plan_issue(
        opened,
        asset,
        names,
        output_pattern,
        recipients_file=names_in_file,
        lock_timeout=lock_timeout,
        per_task=per_task,
    )
    made: list[str | None] = [None] * len(tasks)
    futures = {
        client.submit(_make_copies, text, key=name, pure=False, retries=retries): (n, text)
        for n, (text, name) in enumerate(tasks)
    }
    total = sum(len(json.loads(text)["copies"]) for text, _ in tasks)
    done = 0
    for future in as_completed(futures, loop=client.loop):  # type: ignore[no-untyped-call]
        n, text = futures[future]
        made_json, files = future.result()  # a failed task fails the call: the names stay recorded
        _meshmark._catalog_deliver(opened, text, made_json, files)
        made[n] = made_json
        future.release()
        done += len(json.loads(text)["copies"])
        if progress:
            progress(done, total)
    return _meshmark._catalog_issue_report(
        opened, asset, plan, [m for m in made if m is not None], time.monotonic() - start
    )


def catalog_scan(
    catalog: _meshmark.Catalog | Location,
    suspects: Sequence[Location],
    *,
    client: Any,
    candidates: int = 8,
    more_candidates: int = 4,
    all_candidates: bool = False,
    max_fpp: float = 1e-6,
    trace: bool = True,
    lock_timeout: float = 60.0,
    chunk: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """`catalog scan` with the suspects read on the client's workers; its --json report.

    Suspects go in chunks of `chunk` (default: spread over twice the workers' threads), each
    chunk one task that opens the catalogue once; the report lists them in the order given.
    """
    location = os.fspath(catalog.path if isinstance(catalog, _meshmark.Catalog) else catalog)
    shown = location
    if not location.startswith(("postgresql://", "postgres://")):
        location = os.path.abspath(location)  # the workers run in folders of their own
    given = [os.fspath(s) for s in suspects]
    absolute = [os.path.abspath(s) for s in given]
    if not given:
        raise _meshmark.InvalidOption("name at least one suspect to scan.")
    if chunk is None:
        chunk = max(1, -(-len(absolute) // _slots(client)))
    if chunk < 1:
        raise _meshmark.InvalidOption("chunk must be >= 1.")
    options = {
        "candidates": candidates,
        "more_candidates": more_candidates,
        "all_candidates": all_candidates,
        "max_fpp": max_fpp,
        "trace": trace,
        "lock_timeout": lock_timeout,
    }
    futures = [
        client.submit(_scan, location, absolute[i : i + chunk], dict(options), pure=False)
        for i in range(0, len(absolute), chunk)
    ]
    reports: list[dict[str, Any]] = []
    for n, future in enumerate(futures):
        reports.append(future.result())
        future.release()
        if progress:
            progress(min(len(given), (n + 1) * chunk), len(given))
    merged = dict(reports[0])
    merged["catalog"] = shown
    merged["assets"] = max(r["assets"] for r in reports)
    merged["suspects"] = [s for r in reports for s in r["suspects"]]
    for scan, path in zip(merged["suspects"], given):
        scan["path"] = path  # as given here, not as the workers read it
    return merged


def _summary_progress(label: str) -> Callable[[int, int], None]:
    def show(done: int, total: int) -> None:
        sys.stdout.write(json.dumps({"progress": done / total if total else 1.0}) + "\n")
        sys.stdout.flush()

    return show


def _exit_with_parent() -> None:
    """The command that started this process gone (killed): stop too, as its own work would."""
    import threading
    import time

    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def main(argv: Iterable[str] | None = None) -> int:
    """`python3 -m meshmark.cluster REQUEST.json`: what `meshmark catalog add|scan --scheduler`
    runs. Prints {"progress": f} lines, then {"report": {...}} (or {"error": "..."}), on stdout."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1:
        sys.stderr.write("usage: python3 -m meshmark.cluster REQUEST.json\n")
        return 2
    with open(args[0], encoding="utf-8") as f:
        request = json.load(f)
    _exit_with_parent()
    try:
        from dask.distributed import Client

        with Client(  # type: ignore[no-untyped-call]
            request["scheduler"], timeout=request.get("connect_timeout", 30)
        ) as client:
            show = _summary_progress(request["command"]) if request.get("progress") else None
            if request["command"] == "add":
                report = catalog_add(
                    _meshmark.Catalog(
                        request["catalog"], create=True, lock_timeout=request["lock_timeout"]
                    ),
                    request["inputs"],
                    request["output"],
                    client=client,
                    progress=show,
                    **request["options"],
                )
            elif request["command"] == "issue":
                report = catalog_issue(
                    _meshmark.Catalog(request["catalog"], lock_timeout=request["lock_timeout"]),
                    request["asset"],
                    request["recipients"],
                    request["output"],
                    client=client,
                    progress=show,
                    lock_timeout=request["lock_timeout"],
                    **request["options"],
                )
            elif request["command"] == "scan":
                report = catalog_scan(
                    request["catalog"],
                    request["inputs"],
                    client=client,
                    progress=show,
                    lock_timeout=request["lock_timeout"],
                    **request["options"],
                )
            else:
                raise _meshmark.InvalidOption(f"no cluster command {request['command']!r}.")
    except _meshmark.Error as error:
        print(json.dumps({"error": str(error), "kind": type(error).__name__}), flush=True)
        return 0
    except (OSError, TimeoutError) as error:
        message = f"{request['scheduler']}: cannot reach the Dask scheduler ({error})."
        print(json.dumps({"error": message, "kind": "IoError"}), flush=True)
        return 0
    print(json.dumps({"report": report}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
