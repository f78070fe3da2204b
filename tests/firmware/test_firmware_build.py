"""Build the Uno firmware offline (make -C firmware) and check the flash and RAM budgets."""

from __future__ import annotations

import pytest

from porosense.bench import firmware as fw
from porosense.protocol.model_layout import MAX_BLOB_LEN

pytestmark = pytest.mark.xdist_group("firmware-build")


@pytest.fixture(scope="module")
def built() -> fw.SizeReport:
    why = fw.toolchain_missing()
    if why:
        pytest.skip(why)
    proc = fw.build(quiet=False)
    assert proc.returncode == 0, f"make -C firmware failed:\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}"
    # lib/core is compiled with -Wall -Wextra -Werror: a warning there fails the build above;
    # the project's drivers must be warning-free too.
    src_warnings = [ln for ln in proc.stderr.splitlines() if "warning:" in ln and "src/" in ln]
    assert src_warnings == [], "\n".join(src_warnings)
    return fw.measure_size()


def test_flash_budget(built: fw.SizeReport) -> None:
    print(built)
    assert built.flash <= fw.FLASH_BUDGET


def test_static_ram_budget(built: fw.SizeReport) -> None:
    print(built)
    assert built.static_ram <= fw.RAM_BUDGET
    # What is left must hold the deepest call chain (a command reply encodes a frame on the
    # stack, ~130 B, on top of the dispatcher's locals): keep at least 400 B.
    assert built.stack_room >= 400


def test_hex_written(built: fw.SizeReport) -> None:
    hexfile = fw.ELF.with_suffix(".hex")
    assert hexfile.exists()
    lines = hexfile.read_text().splitlines()
    data_bytes = sum(int(ln[1:3], 16) for ln in lines if ln.startswith(":") and ln[7:9] == "00")
    assert data_bytes == built.flash  # the HEX holds exactly .text + .data


@pytest.mark.bench
def test_bench_firmware_small() -> None:
    result = fw.run("small")
    if result.get("status") == "skipped":
        pytest.skip(result["reason"])
    for line in result["summary"]:
        print(line)
    assert result["flash_ok"] and result["static_ram_ok"]
    sim = result["overruns_100hz"]
    if sim.get("status") == "measured":
        assert sim["overruns"] == 0
        assert sim["samples"] >= 100 * 5
    # Honest rates (issue 19): nothing lost at the advertised maximum with every channel, the
    # IMU and the heaviest model, and that maximum within the highest clean rate found.
    at_limit = result["at_advertised_max"]
    if at_limit.get("status") == "measured":
        assert at_limit["overruns"] == 0 and at_limit["samples_lost"] == 0
    rates = result["max_clean_rates"]
    if rates.get("status") == "measured":
        full = [r for r in rates["configs"] if r["channel_mask"] == 0x1F][0]
        assert full["lost"] == 0 and rates["advertised_max_hz"] <= full["max_clean_hz"]
        # Measured with the heaviest storable model (a flash slot's), reported against the advertised
        # rate; the CI size confirms over 3 s only, so it may find a higher rate than the 60 s run.
        assert rates["model_bytes"] > MAX_BLOB_LEN and rates["measured_max_hz"] == full["max_clean_hz"]
        assert any("advertised" in line and "measured" in line for line in result["summary"])
