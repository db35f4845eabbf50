"""``jaxpg.run.host_work.HostWork``: jobs run in order on one other thread, a checked job's error
comes back on the calling thread, and nothing is left running after ``close``."""

from __future__ import annotations

import threading
import time

import pytest

from jaxpg.run.host_work import HostWork


def test_jobs_run_in_order_on_one_other_thread():
    work = HostWork()
    ran: list[tuple[int, int]] = []
    for i in range(20):
        # Earlier jobs sleep longer: only first-in-first-out keeps the order.
        work.submit(lambda i=i: (time.sleep(0.002 * (20 - i)), ran.append((i, threading.get_ident()))))
    work.wait()
    assert [i for i, _ in ran] == list(range(20))
    assert len({ident for _, ident in ran}) == 1 and ran[0][1] != threading.get_ident()
    work.close()


def test_submit_returns_before_the_job_has_run():
    work = HostWork()
    started, release = threading.Event(), threading.Event()
    work.submit(lambda: (started.set(), release.wait(10)))
    assert started.wait(10) and not release.is_set()  # the caller goes on while the job runs
    release.set()
    work.close()


def test_a_checked_error_comes_back_at_the_next_wait_or_submit():
    work = HostWork()
    work.submit(lambda: (_ for _ in ()).throw(OSError(28, "No space left on device")))
    with pytest.raises(OSError, match="No space left"):
        work.wait()
    work.wait()  # raised once
    gate = threading.Event()
    work.submit(lambda: (gate.wait(10), (_ for _ in ()).throw(ValueError("bad record"))))
    gate.set()
    time.sleep(0.05)
    with pytest.raises(ValueError, match="bad record"):
        for _ in range(200):  # the next checked submit raises it once the job has failed
            work.submit(lambda: None)
            time.sleep(0.01)
    work.close()


def test_an_unchecked_error_is_not_raised():
    work = HostWork()
    work.submit(lambda: 1 / 0, checked=False)
    work.submit(lambda: None)
    work.wait()
    work.close()


def test_close_waits_for_every_job_and_later_jobs_run_at_once():
    work = HostWork()
    done: list[int] = []
    work.submit(lambda: (time.sleep(0.2), done.append(1)), checked=False)
    work.close()
    assert done == [1]
    work.submit(lambda: done.append(threading.get_ident()))
    assert done == [1, threading.get_ident()]
    work.close()  # twice is fine


def test_without_background_jobs_run_on_the_calling_thread():
    work = HostWork(background=False)
    ran: list[int] = []
    work.submit(lambda: ran.append(threading.get_ident()))
    assert ran == [threading.get_ident()]
    with pytest.raises(OSError):
        work.submit(lambda: (_ for _ in ()).throw(OSError(5, "I/O error")))
