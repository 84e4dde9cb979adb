"""Starting the real Rerun viewer bound to 127.0.0.1, and driving a headless one for
screenshots (``rerun.experimental.ViewerClient``).

A headless viewer still renders with wgpu, so it needs a Vulkan driver: on a machine
without a GPU, Mesa's software rasteriser lavapipe (Debian package
``mesa-vulkan-drivers``) is enough; no X server is needed.
"""
from __future__ import annotations

import logging
import os
import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path
from types import TracebackType

log = logging.getLogger(__name__)

_ICD_DIRS = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d", "/usr/local/share/vulkan/icd.d")


def rerun_executable() -> Path:
    """The ``rerun`` binary shipped by the rerun-sdk wheel (package ``rerun_cli``), else the
    first ``rerun`` on PATH."""
    try:
        import rerun_cli

        exe = Path(rerun_cli.__file__).parent / "rerun"
        if exe.is_file():
            return exe
    except ImportError:
        pass
    found = shutil.which("rerun")
    if found is None:
        raise FileNotFoundError("The Rerun viewer binary 'rerun' was not found: neither the rerun_cli "
                                "package (shipped with rerun-sdk) nor PATH has it; expected "
                                "`pip install rerun-sdk==0.41.*` to provide it.")
    return Path(found)


def vulkan_driver_problem() -> str | None:
    """None when a Vulkan loader and at least one installable client driver (ICD) are
    present, else why not, in words."""
    icds = [p for d in _ICD_DIRS if Path(d).is_dir() for p in Path(d).glob("*.json")]
    env_icd = os.environ.get("VK_ICD_FILENAMES") or os.environ.get("VK_DRIVER_FILES")
    if not icds and not env_icd:
        return ("no Vulkan driver (ICD) found in " + ", ".join(_ICD_DIRS) +
                "; install Debian's mesa-vulkan-drivers for the lavapipe software rasteriser")
    import ctypes.util

    if ctypes.util.find_library("vulkan") is None and not any(
            Path(d).glob("libvulkan.so*") for d in ("/usr/lib/x86_64-linux-gnu", "/usr/lib64", "/usr/lib")
            if Path(d).is_dir()):
        return "no Vulkan loader (libvulkan.so.1); install Debian's libvulkan1"
    return None


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for_port(port: int, timeout_s: float, proc: subprocess.Popen | None = None) -> None:
    """Block until 127.0.0.1:port accepts TCP connections (or raise TimeoutError /
    RuntimeError when ``proc`` exits first)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"the rerun viewer exited with code {proc.returncode} before listening "
                               f"on 127.0.0.1:{port}")
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.1)
    raise TimeoutError(f"the rerun viewer did not listen on 127.0.0.1:{port} within {timeout_s:.0f} s")


def start_viewer(port: int, *, headless: bool = False, window_size: tuple[int, int] | None = None,
                 detach: bool = False, log_file: Path | None = None, extra_args: list[str] | None = None,
                 ) -> subprocess.Popen:
    """Start the ``rerun`` viewer listening for gRPC on 127.0.0.1:port (never 0.0.0.0).

    ``detach`` puts it in its own session so it outlives this process (spawn mode).
    The caller owns the process: stop it with :func:`stop_process`.
    """
    args = [str(rerun_executable()), "--bind", "127.0.0.1", "--port", str(port), "--hide-welcome-screen"]
    env = dict(os.environ)
    env.setdefault("RERUN_APP_ONLY", "true")
    if headless:
        args += ["--headless", "--renderer", "vulkan"]
        env.setdefault("WGPU_BACKEND", "vulkan")
        env.setdefault("XDG_RUNTIME_DIR", "/tmp")
    if window_size is not None:
        args += ["--window-size", f"{int(window_size[0])}x{int(window_size[1])}"]
    args += list(extra_args or [])
    out = open(log_file, "ab") if log_file is not None else subprocess.DEVNULL  # noqa: SIM115
    try:
        proc = subprocess.Popen(args, env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=detach)
    finally:
        if log_file is not None:
            out.close()
    log.info("started rerun viewer pid %d on 127.0.0.1:%d (headless=%s)", proc.pid, port, headless)
    return proc


def stop_process(proc: subprocess.Popen, timeout_s: float = 10.0) -> None:
    """Terminate a process this module started (SIGTERM, then SIGKILL), by its own id."""
    if proc.poll() is not None:
        return
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=timeout_s)


class HeadlessViewer:
    """A headless Rerun viewer on 127.0.0.1 driven through ``ViewerClient``; a context
    manager that always stops the process it started.

    >>> with HeadlessViewer(window_size=(1600, 900)) as v:   # doctest: +SKIP
    ...     v.open(Path("runs/x/run.rrd"))
    ...     png = v.screenshot_at(30.0)
    """

    def __init__(self, window_size: tuple[int, int] = (1600, 900), port: int | None = None,
                 startup_timeout_s: float = 60.0, log_file: Path | None = None) -> None:
        problem = vulkan_driver_problem()
        if problem is not None:
            raise RuntimeError(f"cannot start a headless Rerun viewer: {problem}")
        from rerun.experimental import ViewerClient

        self.port = port if port is not None else free_port()
        self.proc = start_viewer(self.port, headless=True, window_size=window_size, log_file=log_file)
        try:
            wait_for_port(self.port, startup_timeout_s, self.proc)
            self.client = ViewerClient.connect(f"rerun+http://127.0.0.1:{self.port}/proxy")
            deadline = time.monotonic() + startup_timeout_s
            while True:
                try:
                    self.client.get_state()
                    break
                except Exception:  # the control channel may need a moment after the port opens
                    if time.monotonic() > deadline:
                        raise
                    time.sleep(0.2)
        except BaseException:
            stop_process(self.proc)
            raise

    def open(self, rrd: Path) -> None:
        """Load a recording and make it the active one."""
        self.client.open(str(Path(rrd).resolve()))

    def timelines(self) -> dict[str, tuple[int, int]]:
        """Timelines of the active recording: name -> (start, end) in ns or sequence numbers."""
        state = self.client.get_state()
        for r in state.recordings:
            if r.store_id == state.active_recording:
                return {tl.name: (int(tl.start), int(tl.end)) for tl in r.timelines}
        return {}

    def screenshot_at(self, sim_time_s: float, max_size: int | None = None, settle_tries: int = 10) -> bytes:
        """Pause the viewer at simulated time ``sim_time_s`` (s) and return a PNG of it.

        The viewer fetches a recording's chunks in the background after ``open``, so the
        first frames may miss data: screenshots are taken until two in a row are the same
        (at most ``settle_tries``). A software rasteriser can also need longer than the
        client's 15 s per request for the first frames; a timed-out request is retried."""
        self.client.set_time("sim_time", duration=float(sim_time_s), play_state="paused")
        previous: bytes | None = None
        png = b""
        for _ in range(max(1, settle_tries)):
            png = self._screenshot(max_size)
            if png == previous:
                break
            previous = png
            time.sleep(0.5)
        return png

    def _screenshot(self, max_size: int | None, attempts: int = 4) -> bytes:
        for attempt in range(1, attempts + 1):
            try:
                return self.client.take_screenshot(max_size=max_size)
            except TimeoutError:
                if attempt == attempts or self.proc.poll() is not None:
                    raise
                log.info("viewer screenshot timed out (attempt %d of %d); retrying", attempt, attempts)
        raise AssertionError("unreachable")

    def close(self) -> None:
        """Stop the viewer process."""
        stop_process(self.proc)

    def __enter__(self) -> "HeadlessViewer":
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
