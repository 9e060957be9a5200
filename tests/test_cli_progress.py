"""The progress bars: a slow first step of ``run`` (the first flight after an install compiles the per-step
kernels) is explained above the bar, and the bar's clock starts at the first step; so is a ``batch`` with no
flight finished for a while."""

import io
import time
from pathlib import Path

from tqdm import tqdm

from scenarios.app.batch import BATCH_SLOW_START_NOTICE, SLOW_START_NOTICE, discover, plan, run_batch
from scenarios.app.cli import progress_steps

SHIPPED = Path(__file__).parents[1] / "scenarios"


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


def test_a_batch_with_no_flight_finished_after_a_while_says_why(tmp_path, capsys):
    """``batch``'s progress bar: no flight finished after ``slow_start_s`` (the workers of the first batch after an
    install compile the per-step kernels) is explained once; the flights still fly."""
    sc = tmp_path / "s.yaml"
    sc.write_text((SHIPPED / "multicopter_survey_calm.yaml").read_text().replace("duration_s: 240", "duration_s: 3"))
    outcome = run_batch(plan(discover([sc])), tmp_path / "out", jobs=1, progress=True, slow_start_s=0.0)
    assert outcome.flown == 1
    assert capsys.readouterr().err.count(BATCH_SLOW_START_NOTICE) == 1
