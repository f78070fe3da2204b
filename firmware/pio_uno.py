"""PlatformIO extra script of [env:uno]: the link flags of the Makefile's image and a flash
budget check that fails the build when the image reaches the flash model store."""

import configparser
import re
import subprocess
from pathlib import Path

Import("env")  # noqa: F821 (provided by PlatformIO's SCons)

HERE = Path(env.subst("$PROJECT_DIR"))  # noqa: F821
ini = configparser.ConfigParser(interpolation=None)
ini.read(HERE / "platformio.ini")
image = ini["uno_image"]
env.Append(LINKFLAGS=(image["image_opt"] + " " + image["image_link"]).split())  # noqa: F821

layout = (HERE / "lib" / "core" / "model_layout.h").read_text()
STORE_BASE = int(re.search(r"kFlashBase = (\d+)", layout).group(1))


def check_budget(source, target, env):
    elf = str(target[0])
    out = subprocess.run([env.subst("$SIZETOOL"), "-A", elf], capture_output=True, text=True, check=True).stdout
    sizes = {m.group(1): int(m.group(2)) for m in re.finditer(r"^\.(text|data)\s+(\d+)", out, re.M)}
    flash = sizes.get("text", 0) + sizes.get("data", 0)
    print(f"porosense: image {flash} B, flash model store from {STORE_BASE} B: {STORE_BASE - flash} B headroom")
    if flash > STORE_BASE:
        raise SystemExit(f"porosense: the image ({flash} B) overlaps the flash model store at {STORE_BASE} B")


env.AddPostAction("$BUILD_DIR/${PROGNAME}.elf", check_budget)  # noqa: F821
