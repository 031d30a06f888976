import subprocess
import sys


def run(*args):
    return subprocess.run([sys.executable, "-m", "aerofid.cli", *args], capture_output=True, text=True)


def test_unknown_command_is_one_line_error_with_status_2():
    r = run("no-such-command")
    assert r.returncode == 2
    assert r.stderr.startswith("error: ")
    assert "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
