"""The ``run`` command's progress bar: a slow first step (the first flight after an install compiles the per-step
kernels) is explained above the bar, and the bar's clock starts at the first step."""

import io
import time

from tqdm import tqdm

from scenarios.app.cli import SLOW_START_NOTICE, progress_steps


def _bar(out: io.StringIO) -> tqdm:
    return tqdm(total=10.0, file=out, mininterval=0.0)


def test_a_slow_first_step_is_explained_and_the_clock_starts_after_it():
    out = io.StringIO()
    bar = _bar(out)
    on_step, notice = progress_steps(bar, notice_after_s=0.05)
    time.sleep(0.3)  # the compiler at work
    on_step(1.0)
    assert SLOW_START_NOTICE in out.getvalue()
    assert bar.n == 1.0 and bar.format_dict["elapsed"] < 0.2  # the clock restarted at the first step
    notice.cancel()
    bar.close()


def test_a_quick_start_says_nothing():
    out = io.StringIO()
    bar = _bar(out)
    on_step, notice = progress_steps(bar, notice_after_s=0.5)
    on_step(1.0)
    on_step(2.0)
    time.sleep(0.7)
    assert SLOW_START_NOTICE not in out.getvalue()
    assert bar.n == 3.0
    bar.close()


def test_without_a_bar_there_is_nothing_to_update():
    assert progress_steps(None) == (None, None)
