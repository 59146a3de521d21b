"""The C++ binding as users install and run it (issue #18).

(a) `cmake --install` of the tree's build (bindings/cpp/build, from `make test-cpp`) into a
    temporary prefix lays out include/openair/*.hpp, the library, the CMake package `openair`
    (config, targets, version file) and openair.pc.
(b) bindings/cpp/examples builds out of tree against that prefix through
    find_package(openair CONFIG) (CMAKE_PREFIX_PATH); the built poster answers --help and posts
    to a reference server. A version request the package does not satisfy is refused.
(c) A tiny program compiles and links with `pkg-config --cflags --libs openair` alone.
(d) The examples and tools answer --help (exit 0) and a bad command line (--port abc, ...) with
    one line on stderr and exit code 2.

The build comes from `make test-cpp` (or `make cpp`); the tests skip when it is missing, unless
OPENAIR_REQUIRE_BINDINGS=1 (set by `make test`), which makes them fail.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from bindings_support import ROOT, require
from server_thread import ReferenceServer

from openair.client import BlockingModule
from openair.protocol.content import RetrieveSpec

CPP_DIR = ROOT / "bindings" / "cpp"
BUILD = CPP_DIR / "build"
LIBRARY = BUILD / "libopenair_client.a"
EXAMPLES = CPP_DIR / "examples"
BUILD_TIMEOUT = 300.0  # a bound on one configure or build step: a hang fails instead of blocking
RUN_TIMEOUT = 60.0


def _version() -> str:
    """The project version, from bindings/cpp/CMakeLists.txt."""
    text = (CPP_DIR / "CMakeLists.txt").read_text(encoding="utf-8")
    found = re.search(r"project\(\S+ VERSION (\d+\.\d+\.\d+)", text)
    assert found is not None
    return found.group(1)


def _run(*args: str | Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run a build step; fail with its output when it fails."""
    done = subprocess.run(
        [str(a) for a in args], capture_output=True, text=True, env=env, timeout=BUILD_TIMEOUT
    )
    assert done.returncode == 0, f"{args}:\n{done.stdout}\n{done.stderr}"
    return done


def _only(prefix: Path, pattern: str) -> Path:
    """The one file under `prefix` matching `pattern` (the library directory may be lib64...)."""
    found = sorted(prefix.glob(pattern))
    assert len(found) == 1, (pattern, found)
    return found[0]


# -- (a) cmake --install ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def prefix(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tree's build installed into a fresh prefix."""
    require("C++ binding", "make test-cpp", LIBRARY, BUILD / "openair-shim")
    where = tmp_path_factory.mktemp("cpp-install") / "prefix"
    _run("cmake", "--install", BUILD, "--prefix", where)
    return where


def test_install_lays_out_headers_library_package_and_pc_file(prefix: Path) -> None:
    shipped = {p.name for p in (CPP_DIR / "include" / "openair").glob("*.hpp")}
    installed = {p.name for p in (prefix / "include" / "openair").glob("*.hpp")}
    assert installed == shipped | {"version.hpp"}
    version_header = (prefix / "include" / "openair" / "version.hpp").read_text(encoding="utf-8")
    assert f'#define OPENAIR_VERSION "{_version()}"' in version_header
    _only(prefix, "lib*/libopenair_client.a")
    package = _only(prefix, "lib*/cmake/openair/openairConfig.cmake").parent
    assert {"openairConfigVersion.cmake", "openairTargets.cmake"} <= {
        p.name for p in package.iterdir()
    }
    assert "openair::client" in (package / "openairTargets.cmake").read_text(encoding="utf-8")
    assert (prefix / "bin" / "openair-shim").is_file()


def _pkg_config_env(prefix: Path) -> dict[str, str]:
    pc_dir = _only(prefix, "lib*/pkgconfig/openair.pc").parent
    return {**os.environ, "PKG_CONFIG_PATH": str(pc_dir)}


def test_pkg_config_knows_the_installed_version(prefix: Path) -> None:
    if shutil.which("pkg-config") is None:
        pytest.skip("pkg-config is not installed")
    done = _run("pkg-config", "--modversion", "openair", env=_pkg_config_env(prefix))
    assert done.stdout.strip() == _version()


# -- (b) the examples, out of tree, through find_package --------------------------------------


@pytest.fixture(scope="module")
def examples(prefix: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """bindings/cpp/examples configured and built against the installed package only."""
    build = tmp_path_factory.mktemp("cpp-examples")
    _run("cmake", "-S", EXAMPLES, "-B", build, f"-DCMAKE_PREFIX_PATH={prefix}")
    _run("cmake", "--build", build, "--parallel", "2")
    return build


def test_the_examples_build_against_the_installed_package(prefix: Path, examples: Path) -> None:
    cache = (examples / "CMakeCache.txt").read_text(encoding="utf-8")
    found = re.search(r"^openair_DIR:PATH=(.*)$", cache, re.MULTILINE)
    assert found is not None
    assert Path(found.group(1)).resolve().is_relative_to(prefix.resolve())
    done = subprocess.run(
        [str(examples / "poster"), "--help"], capture_output=True, text=True, timeout=RUN_TIMEOUT
    )
    assert done.returncode == 0, done.stderr
    assert "Usage: poster" in done.stdout and "--port" in done.stdout


@pytest.fixture
def server() -> Iterator[ReferenceServer]:
    srv = ReferenceServer()
    try:
        yield srv
    finally:
        srv.stop()


def test_the_installed_poster_posts_to_a_reference_server(
    examples: Path, server: ReferenceServer
) -> None:
    content = "posted by an installed openair ✓"
    done = subprocess.run(
        [str(examples / "poster"), "--port", str(server.port), "--name", "InstalledPoster",
         "--type", "Install.Cpp.Hello", "--content", content],
        capture_output=True, text=True, timeout=RUN_TIMEOUT,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    posted = re.fullmatch(r"posted Install\.Cpp\.Hello to WB1 id (\S+)\n", done.stdout)
    assert posted is not None, done.stdout
    with BlockingModule("InstallCheck", port=server.port, keepalive=None) as checker:
        stored = checker.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Install.*", latest=5))
    assert [(m.id, m.sender, m.content) for m in stored] == [
        (posted.group(1), "InstalledPoster", content)
    ]


def _find_package_probe(prefix: Path, tmp_path: Path, wanted: str) -> str:
    """Configure a project asking for find_package(openair `wanted`); return what it found."""
    tmp_path.mkdir()
    (tmp_path / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.16)\nproject(probe LANGUAGES CXX)\n"
        f"find_package(openair {wanted} CONFIG)\n"
        'message(STATUS "probe: found=${openair_FOUND} version=${openair_VERSION}")\n',
        encoding="utf-8",
    )
    done = _run("cmake", "-S", tmp_path, "-B", tmp_path / "build", f"-DCMAKE_PREFIX_PATH={prefix}")
    found = re.search(r"probe: (.*)", done.stdout)
    assert found is not None, done.stdout
    return found.group(1)


def test_the_version_file_accepts_the_same_minor_version_only(prefix: Path, tmp_path: Path) -> None:
    version = _version()
    major, minor, _ = version.split(".")
    assert _find_package_probe(prefix, tmp_path / "same", f"{major}.{minor}") == (
        f"found=1 version={version}"
    )
    newer = _find_package_probe(prefix, tmp_path / "newer", f"{major}.{int(minor) + 1}")
    assert newer.startswith("found=0"), newer


# -- (c) pkg-config ---------------------------------------------------------------------------

_TINY = """\
#include <iostream>

#include "openair/codec.hpp"
#include "openair/message.hpp"
#include "openair/version.hpp"

int main() {
    openair::message m = openair::make_message("Install.Tiny", "Tiny", "WB1");
    std::cout << openair::version << ' ' << openair::decode_message(openair::encode_message(m)).type
              << std::endl;
    return 0;
}
"""


def test_a_tiny_program_builds_with_pkg_config_alone(prefix: Path, tmp_path: Path) -> None:
    if shutil.which("pkg-config") is None or shutil.which("c++") is None:
        pytest.skip("pkg-config or a C++ compiler is not installed")
    env = _pkg_config_env(prefix)
    flags = _run("pkg-config", "--cflags", "--libs", "openair", env=env).stdout.split()
    assert any(f.startswith("-I") and str(prefix) in f for f in flags), flags
    source = tmp_path / "tiny.cpp"
    source.write_text(_TINY, encoding="utf-8")
    program = tmp_path / "tiny"
    _run("c++", "-std=c++17", source, "-o", program, *flags)
    done = _run(program)
    assert done.stdout == f"{_version()} Install.Tiny\n"


# -- (d) command lines ------------------------------------------------------------------------

PROGRAMS = ("poster", "reader", "openair-shim", "openair-shim-broken", "openair-bench")


@pytest.mark.parametrize("program", PROGRAMS)
def test_every_program_answers_help(program: str) -> None:
    require("C++ binding", "make test-cpp", BUILD / program)
    done = subprocess.run(
        [str(BUILD / program), "--help"], capture_output=True, text=True, timeout=RUN_TIMEOUT
    )
    assert (done.returncode, done.stderr) == (0, "")
    assert f"Usage: {program}" in done.stdout


BAD_COMMAND_LINES = [
    ("poster", "--port", "abc"),
    ("poster", "--port", "70000"),
    ("poster", "--no-such-option"),
    ("reader", "--port", "abc"),
    ("reader", "--count", "0"),
    ("reader", "--timeout-ms", "soon"),
    ("openair-shim", "--port", "abc"),
    ("openair-shim-broken", "--break", "no-such-break"),
    ("openair-shim-broken",),
    ("openair-bench", "post", "127.0.0.1", "abc", "1", "1"),
    ("openair-bench", "decode", "file.xml", "-3"),
]


@pytest.mark.parametrize("argv", BAD_COMMAND_LINES, ids=" ".join)
def test_a_bad_command_line_is_one_line_and_exit_code_2(argv: tuple[str, ...]) -> None:
    program, *args = argv
    require("C++ binding", "make test-cpp", BUILD / program)
    done = subprocess.run(
        [str(BUILD / program), *args], capture_output=True, text=True, timeout=RUN_TIMEOUT
    )
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert done.stdout == ""
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{program}: "), done.stderr
    assert f"usage: {program} --help" in lines[0]
    assert "stoi" not in lines[0] and "terminate" not in lines[0]
