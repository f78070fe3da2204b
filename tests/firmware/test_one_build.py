"""One firmware image, whichever way it is built: platformio.ini declares the image's flags
([uno_image]), the Makefile reads them, the PlatformIO extra script (pio_uno.py) adds the same
link flags and fails a build that reaches the flash model store. Built here offline with the
installed avr-gcc, from the flags that platformio.ini declares, and checked against the store's
base (kFlashBase of lib/core/model_layout.h)."""

from __future__ import annotations

import configparser
import re
import shlex
import subprocess
from pathlib import Path

import pytest

from porosense.bench import firmware as fw

pytestmark = pytest.mark.xdist_group("firmware-build")

FW_DIR = fw.FIRMWARE_DIR
PIO_BUILD = "build/pio-flags"  # inside firmware/build (ignored by git)


def _ini() -> configparser.ConfigParser:
    ini = configparser.ConfigParser(interpolation=None)
    ini.read(FW_DIR / "platformio.ini")
    return ini


def _resolve(ini: configparser.ConfigParser, value: str) -> str:
    """PlatformIO's ${section.option} references, resolved."""
    return re.sub(r"\$\{(\w+)\.(\w+)\}", lambda m: _resolve(ini, ini[m.group(1)][m.group(2)]), value)


def _store_base() -> int:
    text = (FW_DIR / "lib" / "core" / "model_layout.h").read_text()
    return int(re.search(r"kFlashBase = (\d+)", text).group(1))


class _StubEnv:
    """The part of PlatformIO's SCons environment that pio_uno.py uses."""

    def __init__(self) -> None:
        self.linkflags: list[str] = []
        self.post_actions: list = []

    def subst(self, s: str) -> str:
        return {"$PROJECT_DIR": str(FW_DIR), "$SIZETOOL": "avr-size"}.get(s, s)

    def Append(self, LINKFLAGS=()):  # noqa: N802, N803 (SCons' names)
        self.linkflags += list(LINKFLAGS)

    def AddPostAction(self, target, action):  # noqa: N802
        self.post_actions.append(action)


def _run_extra_script() -> tuple[_StubEnv, dict]:
    env = _StubEnv()
    scope = {"Import": lambda name: None, "env": env, "__file__": str(FW_DIR / "pio_uno.py")}
    exec(compile((FW_DIR / "pio_uno.py").read_text(), "pio_uno.py", "exec"), scope)
    return env, scope


@pytest.fixture(scope="module")
def pio_flags() -> dict:
    if FW_DIR is None:
        pytest.skip("installed package: no firmware sources")
    ini = _ini()
    uno = ini["env:uno"]
    build_flags = shlex.split(_resolve(ini, uno["build_flags"]))
    env, _ = _run_extra_script()
    return {
        "defines": [f for f in build_flags if f.startswith("-D")],
        "compile": [f for f in build_flags if not f.startswith("-D") and not f.startswith("-W") and f != "-fno-rtti"],
        "link": env.linkflags,
        "unflags": shlex.split(uno.get("build_unflags", "")),
        "extra_scripts": uno.get("extra_scripts", ""),
    }


def test_makefile_builds_with_the_flags_platformio_declares(pio_flags: dict) -> None:
    made = subprocess.run(["make", "-s", "-C", str(FW_DIR), "print-flags"], capture_output=True, text=True, check=True)
    make_flags = made.stdout.split()
    wanted = pio_flags["defines"] + [f for f in pio_flags["compile"] if not f.startswith("-std")] + pio_flags["link"]
    missing = [f for f in wanted if f not in make_flags]
    assert missing == [], f"platformio.ini declares flags the Makefile does not use: {missing}"
    # PlatformIO's own -Os/-flto defaults are replaced by the declared ones, and the budget
    # check runs after the link.
    assert {"-Os", "-flto", "-fuse-linker-plugin"} <= set(pio_flags["unflags"])
    assert "pio_uno.py" in pio_flags["extra_scripts"]
    assert "-DPOROSENSE_STATIC_PORTS=1" in pio_flags["defines"]


@pytest.fixture(scope="module")
def pio_elf(pio_flags: dict) -> Path:
    why = fw.toolchain_missing()
    if why:
        pytest.skip(why)
    defs = "-mmcu=atmega328p -DF_CPU=16000000L -DARDUINO=10807 -DARDUINO_AVR_UNO -DARDUINO_ARCH_AVR"
    args = [
        "make",
        "-s",
        "-C",
        str(FW_DIR),
        f"BUILD={PIO_BUILD}",
        f"DEFS={defs} {' '.join(pio_flags['defines'])}",
        f"OPT={' '.join(f for f in pio_flags['compile'] if not f.startswith('-std'))}",
        # The extra script's link flags; the Makefile adds DEFS and OPT before them as
        # PlatformIO's link line carries its compile flags.
        f"LDLINK={' '.join(pio_flags['link'])}",
        f"{PIO_BUILD}/porosense.hex",
    ]
    (FW_DIR / "build").mkdir(exist_ok=True)
    import fcntl

    with open(FW_DIR / "build" / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        proc = subprocess.run(args, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, f"build with platformio.ini's flags failed:\n{proc.stderr[-3000:]}"
    return FW_DIR / PIO_BUILD / "porosense.elf"


def test_platformio_image_fits_below_the_flash_store(pio_elf: Path) -> None:
    size = fw.measure_size(pio_elf)
    base = _store_base()
    print(
        f"image built with platformio.ini's flags: {size.flash} B; store base {base} B; headroom {base - size.flash} B"
    )
    assert size.flash <= base
    # At least 1 KB of headroom for what comes next (measured 2,292 B when this was written).
    assert base - size.flash >= 1024
    assert size.static_ram <= fw.RAM_BUDGET


def test_platformio_image_is_the_makefile_image(pio_elf: Path) -> None:
    proc = fw.build()
    assert proc.returncode == 0, proc.stderr[-3000:]
    ours = (FW_DIR / "build" / "porosense.hex").read_text()
    pio = pio_elf.with_suffix(".hex").read_text()
    assert fw.measure_size(pio_elf).flash == fw.measure_size().flash
    assert pio == ours, "the image built with platformio.ini's flags differs from the Makefile's"


def test_budget_script_refuses_an_image_over_the_store(pio_elf: Path, capsys) -> None:
    env, scope = _run_extra_script()
    (check,) = env.post_actions
    check(None, [pio_elf], env)
    assert "headroom" in capsys.readouterr().out
    scope["STORE_BASE"] = fw.measure_size(pio_elf).flash - 1  # the same image, one byte too large
    with pytest.raises(SystemExit, match="overlaps the flash model store"):
        check(None, [pio_elf], env)


def test_makefile_budget_check_is_fatal(tmp_path: Path) -> None:
    why = fw.toolchain_missing()
    if why:
        pytest.skip(why)
    fw.build()
    proc = subprocess.run(
        ["make", "-s", "-C", str(FW_DIR), "size", "FLASH_BUDGET=1000"], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode != 0 and "BUDGET EXCEEDED" in proc.stdout


def test_the_end_the_firmware_checks_at_boot_is_its_image_end() -> None:
    """main() hands __data_load_end to the model store (ModelStore::set_image_end), which ignores
    the flash store when the image reaches it (HELLO then lacks FLASH_STORE): that symbol must
    be the image's end in flash, .text + .data, the figure the budget checks."""
    why = fw.toolchain_missing()
    if why:
        pytest.skip(why)
    proc = fw.build()
    assert proc.returncode == 0, proc.stderr[-3000:]
    nm = subprocess.run(["avr-nm", str(fw.ELF)], capture_output=True, text=True, check=True).stdout
    (end,) = [int(line.split()[0], 16) for line in nm.splitlines() if line.endswith(" __data_load_end")]
    assert "__data_load_end" in (FW_DIR / "src" / "main.cpp").read_text()
    assert end == fw.measure_size().flash <= _store_base()
