"""Four processes writing one registry at once (spawned, so each has its own connections): no
record is lost and no writer fails, on SQLite (WAL, ``BEGIN IMMEDIATE``, busy timeout) and on
PostgreSQL.  The registry does not exist before they start, so they also race to create it."""

from __future__ import annotations

import multiprocessing
import queue

from _fixtures_registry import make_asset, record_many

from meshwm.apps.registry import Registry

PROCESSES = 4
EMBEDS = 25
#: Inputs the processes share: embed i of every process marks input i % ASSETS.
ASSETS = 10


def test_four_processes_record_every_copy(target):
    context = multiprocessing.get_context("spawn")
    start = context.Barrier(PROCESSES)
    results = context.Queue()
    workers = [
        context.Process(target=record_many, args=(target, worker, EMBEDS, ASSETS, start, results))
        for worker in range(PROCESSES)
    ]
    for process in workers:
        process.start()
    try:
        outcomes = dict(results.get(timeout=120) for _ in workers)
    except queue.Empty:
        outcomes = {}
    finally:
        for process in workers:
            process.join(timeout=30)
            if process.is_alive():
                process.kill()
                process.join()
    results.close()
    results.join_thread()
    errors = {worker: out for worker, out in outcomes.items() if isinstance(out, str)}
    assert not errors and len(outcomes) == PROCESSES, errors or "a worker did not report"
    assert all(process.exitcode == 0 for process in workers)

    pairs = [pair for out in outcomes.values() for pair in out]
    with Registry.open(target, create=False) as registry:
        assets, copies = registry.assets(), registry.copies()
        assert len(copies) == PROCESSES * EMBEDS == 100
        assert len(assets) == ASSETS
        assert sorted(c.id for c in copies) == sorted(copy_id for _, copy_id in pairs)
        per_input = {a.input_sha256: a for a in assets}
        for index in range(ASSETS):
            expected = make_asset(index, reference_bytes=100_000)
            record = per_input[expected.input_sha256]
            shared = len(range(index, EMBEDS, ASSETS))
            assert record.copies == PROCESSES * shared
            assert registry.references(record.id) == expected.references
        assert len(registry.descriptors()[0]) == ASSETS
