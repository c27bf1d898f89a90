"""Start the nodes as separate processes without ``ros2 launch`` (the demo, the tests and
the benchmark use this): ``python -m serial_dynamics.ros.<node> --ros-args -p ...``.

Every child gets SIGTERM if its parent dies (Linux), and ``stop`` interrupts it
(SIGINT, like Ctrl-C) and kills it if it does not exit in time.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile


def ros_value(v) -> str:
    """A Python value as a --ros-args ``-p name:=value`` (YAML) literal."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if v == v and abs(v) != float("inf") else (".nan" if v != v else
                                                                   (".inf" if v > 0 else "-.inf"))
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(ros_value(x) for x in v) + "]"
    if isinstance(v, str) and v == "":
        return "''"
    return str(v)


def _die_with_parent():
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


class NodeProcess:
    """One node in its own process; output goes to a log file (``self.log_path``)."""

    def __init__(self, module: str, params: dict | None = None, ros_args=(), env=None,
                 log_dir=None):
        self.module, self.stopped = module, False
        self.cmd = [sys.executable, "-m", f"serial_dynamics.ros.{module}", "--ros-args"]
        for name, value in (params or {}).items():
            self.cmd += ["-p", f"{name}:={ros_value(value)}"]
        self.cmd += list(ros_args)
        fd, self.log_path = tempfile.mkstemp(prefix=f"{module}-", suffix=".log", dir=log_dir)
        self._log = os.fdopen(fd, "w")
        self.proc = subprocess.Popen(self.cmd, stdout=self._log, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL, env=env,
                                     preexec_fn=_die_with_parent if sys.platform == "linux" else None)

    def output(self) -> str:
        if not self._log.closed:
            self._log.flush()
        with open(self.log_path) as fh:
            return fh.read()

    def running(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 5.0) -> int:
        self.stopped = True
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._log.close()
        return self.proc.returncode

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
