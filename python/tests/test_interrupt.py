"""The GIL is released while felt runs, and Ctrl-C interrupts a run as it does at the CLI."""

import signal
import subprocess
import sys
import textwrap
import threading

import felt

LONG = "float s = 0;\nfor (int i = 0; i < 500000000; i++) { s += 1; }\n"


def test_python_threads_run_while_felt_runs(tmp_path):
    """The script saves a file, loops, then saves another. This thread sees the first file
    while the second is not there yet only if it ran while felt did; with the GIL held it
    could look only after the run, when both exist."""
    first, last = tmp_path / "first.vdb", tmp_path / "last.vdb"
    script = (
        "domain d((0,0,0), (1,1,1), (0,0,0), 0.5);\nscalarcache c(d);\ncachewrite(c, 1.0);\n"
        f'cachesave(c, "{first}");\n'
        "float s = 0;\nfor (int i = 0; i < 5000000; i++) { s += 1; }\n"
        f'cachesave(c, "{last}");\n'
    )
    failures = []

    def run():
        try:
            felt.Session().run(script)
        except Exception as error:  # reported below, in the test's thread
            failures.append(error)

    runner = threading.Thread(target=run)
    runner.start()
    while runner.is_alive() and not first.exists():
        runner.join(0.001)
    last_was_there = last.exists()
    runner.join()
    assert not failures, failures
    assert first.exists() and last.exists()
    assert not last_was_there


def test_sigint_raises_keyboard_interrupt_and_the_session_goes_on():
    child = textwrap.dedent(
        f"""
        import sys, felt
        session = felt.Session()
        print("running", flush=True)
        try:
            session.run({LONG!r})
        except KeyboardInterrupt:
            print("interrupted", flush=True)
        print(session.run('print(6 * 7);'), end="", flush=True)
        """
    )
    process = subprocess.Popen(
        [sys.executable, "-c", child], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert process.stdout.readline() == "running\n"
    # SIGINT until the run has begun and answered (one sent before the run starts is Python's
    # own KeyboardInterrupt, which the child would not survive, so wait a moment first).
    threading.Event().wait(0.5)
    process.send_signal(signal.SIGINT)
    try:
        # A hang guard only: an uninterrupted run would take minutes.
        out, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 0, err
    assert out == "interrupted\n42\n"
