"""The modem-line shim: an unchanged C driver that sets DTR/RTS talks to `sim --pty`.

The driver here does what both open-source Giraff drivers do on opening the port
(wire-facts, "Opening the port"): TIOCMGET, then TIOCMSET with DTR and RTS raised. The
other checks run ioctls from a Python child under LD_PRELOAD (CPython's fcntl.ioctl is
libc's ioctl), each with a positive control showing the shim is loaded in it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from giraff_console.sim import modem_shim
from giraff_console.sim.modem_shim import ShimError, c_compiler, shim_path

# A driver, build or child that takes longer than this on a loaded machine has hung.
CHILD_TIMEOUT = 30.0

DRIVER = r"""
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

/* Reads until the buffer ends with the board's prompt; -1 after 5 s without it. */
static int read_to_prompt(int fd, char *buf, size_t size) {
    size_t used = 0;
    time_t deadline = time(NULL) + 5;
    buf[0] = '\0';
    while (used < 6 || strcmp(buf + used - 6, "OK >\r\n") != 0) {
        struct pollfd p = {fd, POLLIN, 0};
        if (time(NULL) > deadline || poll(&p, 1, 500) < 0)
            return -1;
        if (!(p.revents & POLLIN))
            continue;
        ssize_t n = read(fd, buf + used, size - 1 - used);
        if (n <= 0)
            return -1;
        used += (size_t)n;
        buf[used] = '\0';
    }
    return 0;
}

int main(int argc, char **argv) {
    char buf[4096];
    if (argc != 2)
        return 2;
    int fd = open(argv[1], O_RDWR | O_NOCTTY);
    if (fd < 0) { perror(argv[1]); return 2; }
    struct termios t;
    tcgetattr(fd, &t);
    cfmakeraw(&t);
    cfsetispeed(&t, B115200);
    cfsetospeed(&t, B115200);
    tcsetattr(fd, TCSANOW, &t);
    int lines;
    if (ioctl(fd, TIOCMGET, &lines) == -1) { perror("TIOCMGET"); return 1; }
    lines |= TIOCM_DTR | TIOCM_RTS;
    if (ioctl(fd, TIOCMSET, &lines) == -1) { perror("TIOCMSET"); return 1; }
    if (read_to_prompt(fd, buf, sizeof buf) != 0) { fprintf(stderr, "no greeting\n"); return 3; }
    if (write(fd, "get cdis\r", 9) != 9) { perror("write"); return 2; }
    if (read_to_prompt(fd, buf, sizeof buf) != 0) { fprintf(stderr, "no reply\n"); return 3; }
    fputs(buf, stdout);
    return 0;
}
"""


@pytest.fixture(scope="module")
def compiler() -> list[str]:
    try:
        return c_compiler()
    except ShimError as error:
        pytest.skip(f"no C compiler to build the shim and the test driver: {error}")


@pytest.fixture(scope="module")
def shim(compiler, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shim as `giraff-console sim --modem-shim` builds it, in a cache of its own."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.mktemp("cache")))
        return shim_path()


@pytest.fixture(scope="module")
def driver(compiler, tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("driver")
    (folder / "driver.c").write_text(DRIVER)
    built = folder / "driver"
    result = subprocess.run(
        [*compiler, "-o", str(built), str(folder / "driver.c")],
        capture_output=True, text=True, timeout=CHILD_TIMEOUT,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return built


# The child's helpers: each ioctl's result, or the errno name it failed with.
IOCTLS = """
import errno, fcntl, os, struct, termios
def modem(fd, request, value=0):
    try:
        return struct.unpack("i", fcntl.ioctl(fd, request, struct.pack("i", value)))[0]
    except OSError as error:
        return errno.errorcode[error.errno]
def lines(fd):
    got = modem(fd, termios.TIOCMGET)
    if isinstance(got, str):
        return got
    names = ("DTR", "RTS", "CTS", "DSR", "CD", "RI")
    return " ".join(n for n in names if got & getattr(termios, "TIOCM_" + n))
master, slave = os.openpty()
"""


def run(command: list[str], preload: Path | None) -> subprocess.CompletedProcess:
    # The C locale, for strerror's words in English.
    env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"} | {"LC_ALL": "C"}
    if preload is not None:
        env["LD_PRELOAD"] = str(preload)
    result = subprocess.run(command, env=env, capture_output=True, timeout=CHILD_TIMEOUT)
    # Decoded by hand: text=True would turn the board's \r\n into \n.
    result.stdout, result.stderr = result.stdout.decode(), result.stderr.decode()
    return result


def python(code: str, preload: Path | None) -> subprocess.CompletedProcess:
    """`code` in a Python child, after the IOCTLS helpers."""
    result = run([sys.executable, "-c", IOCTLS + code], preload)
    assert result.returncode == 0, result.stderr
    return result


def test_without_the_shim_a_c_driver_fails_on_the_pty(sim_pty, driver):
    result = run([str(driver), sim_pty], preload=None)
    assert result.returncode == 1
    assert result.stderr.strip() == "TIOCMGET: Inappropriate ioctl for device"


def test_with_the_shim_the_same_driver_reads_cdis(sim_pty, driver, shim):
    result = run([str(driver), sim_pty], preload=shim)
    assert result.returncode == 0, result.stderr
    assert result.stdout == "F*00000000\r\nOK >\r\n"


def test_lines_set_are_read_back_with_the_boards_lines_raised(shim):
    code = """
print(lines(slave))
modem(slave, termios.TIOCMBIC, termios.TIOCM_DTR)
print(lines(slave))
again = os.open(os.ttyname(slave), os.O_RDWR | os.O_NOCTTY)
print(lines(again))
modem(again, termios.TIOCMSET, 0)
print(lines(slave))
modem(slave, termios.TIOCMBIS, termios.TIOCM_RTS)
print(lines(slave))
"""
    assert python(code, shim).stdout.splitlines() == [
        "DTR RTS CTS DSR CD",  # as Linux opens a serial port: DTR and RTS up
        "RTS CTS DSR CD",
        "RTS CTS DSR CD",  # the lines are the port's, whichever fd asks
        "CTS DSR CD",
        "RTS CTS DSR CD",
    ]


def test_a_failure_on_anything_but_a_pty_stays_a_failure(shim, tmp_path):
    (tmp_path / "file").write_text("x")
    code = f"""
read_end, _ = os.pipe()
others = [os.open("/dev/null", os.O_RDWR), read_end, os.open({str(tmp_path / "file")!r}, 0)]
print(lines(slave))
for fd in others:
    print(lines(fd), modem(fd, termios.TIOCMSET, termios.TIOCM_DTR))
"""
    without = python(code, preload=None).stdout.splitlines()
    with_shim = python(code, shim).stdout.splitlines()
    assert with_shim[0] == "DTR RTS CTS DSR CD"  # the shim is loaded in this child
    assert without[0] == "ENOTTY"
    assert with_shim[1:] == without[1:] == ["ENOTTY ENOTTY"] * 3


def test_other_requests_on_a_pty_pass_through(shim):
    code = """
print(lines(slave))
try:
    fcntl.ioctl(slave, termios.TIOCGSERIAL, bytes(128))
except OSError as error:
    print(errno.errorcode[error.errno])
print(fcntl.ioctl(slave, termios.FIONREAD, struct.pack("i", 7)) == struct.pack("i", 0))
print(lines(master))  # the master side is not a port a driver opens
"""
    assert python(code, shim).stdout.splitlines() == [
        "DTR RTS CTS DSR CD",
        "ENOTTY",
        "True",
        "ENOTTY",
    ]


def test_pyserial_opens_a_pty_but_cannot_set_dtr_without_the_shim(shim):
    # What the README says of Python programs: the open succeeds (pyserial ignores
    # ENOTTY there), but setting a line or reading one afterwards raises.
    code = """
import serial
port = serial.Serial(os.ttyname(slave), 115200)
for step in ("port.dtr = False", "port.rts = True", "print(port.cts, port.dsr, port.cd)"):
    try:
        exec(step)
    except OSError as error:
        print(errno.errorcode[error.errno])
print(lines(slave))
"""
    assert python(code, preload=None).stdout.splitlines() == ["ENOTTY"] * 4
    assert python(code, shim).stdout.splitlines() == ["True True True", "RTS CTS DSR CD"]


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    return tmp_path / "cache" / "giraff-console"


def test_the_shim_is_built_once_into_the_cache(compiler, cache):
    first = shim_path()
    assert first.parent == cache
    built_at = first.stat().st_mtime_ns
    assert shim_path() == first
    assert first.stat().st_mtime_ns == built_at
    assert cache.stat().st_mode & 0o077 == 0  # only its owner chooses what runs in a driver


def test_a_changed_source_is_built_afresh(compiler, cache, tmp_path, monkeypatch):
    first = shim_path()
    changed = tmp_path / "package"
    changed.mkdir()
    source = (Path(modem_shim.__file__).parent / "modem_shim.c").read_bytes()
    (changed / "modem_shim.c").write_bytes(source + b"/* changed */\n")
    monkeypatch.setattr(modem_shim, "files", lambda package: changed)
    second = shim_path()
    assert second != first
    assert second.is_file() and first.is_file()


def test_no_compiler_says_what_to_install(cache, tmp_path, monkeypatch):
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))  # no cc, gcc or clang in it
    with pytest.raises(ShimError, match=r"C compiler.*build-essential"):
        shim_path()
    monkeypatch.setenv("CC", "no-such-cc")
    with pytest.raises(ShimError, match=r"\$CC is 'no-such-cc'.*build-essential"):
        shim_path()
    assert not cache.exists() or not list(cache.glob("*.so"))


def test_a_failed_build_shows_the_compilers_words(cache, monkeypatch):
    monkeypatch.setenv("CC", "false")  # a "compiler" that fails without a word
    with pytest.raises(ShimError, match=r"false -shared .* failed"):
        shim_path()
    assert list(cache.iterdir()) == []  # no half-built library, no build folder left


def test_the_installed_package_builds_the_shim_from_its_own_source(wheel, compiler, tmp_path):
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    assert (site / "giraff_console" / "sim" / "modem_shim.c").is_file()
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env |= {"PYTHONPATH": str(site), "XDG_CACHE_HOME": str(tmp_path / "cache")}
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console.sim.modem_shim"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=CHILD_TIMEOUT,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    built = Path(result.stdout.strip())
    assert built.parent == tmp_path / "cache" / "giraff-console"
    assert built.is_file()


def test_sim_modem_shim_prints_the_library_to_preload(compiler, cache):
    result = subprocess.run([sys.executable, "-m", "giraff_console", "sim", "--modem-shim"],
                            capture_output=True, text=True, timeout=CHILD_TIMEOUT)  # fmt: skip
    assert result.returncode == 0, result.stderr
    path = Path(result.stdout.strip())
    assert path.parent == cache and path.is_file()
