"""The Java binding as users install and use it (issue #18).

(a) `mvn -o -q install -DskipTests` (on a copy of bindings/java, so the tree's target/ is left
    alone) puts org.openair:openair:<version> into the local Maven repository (~/.m2): the jar,
    whose classes include the API, and its pom with those coordinates.
(b) bindings/java/examples/consumer, a separate project whose pom depends on
    org.openair:openair, builds offline against the installed artifact; its main connects to a
    reference server started here, prints the library version and posts one message, which a
    Python module then retrieves.

Maven runs offline (-o): plugins come from the local repository. The tests skip without
`mvn` and `java`, unless OPENAIR_REQUIRE_BINDINGS=1 (set by `make test`), which makes them fail.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from bindings_support import ROOT
from server_thread import ReferenceServer

from openair.client import BlockingModule
from openair.protocol.content import RetrieveSpec

JAVA_DIR = ROOT / "bindings" / "java"
CONSUMER = JAVA_DIR / "examples" / "consumer"
REPOSITORY = Path.home() / ".m2" / "repository"  # Maven's default local repository
POM = "{http://maven.apache.org/POM/4.0.0}"
MAVEN_TIMEOUT = 300.0  # a bound on one Maven run: a hang fails instead of blocking
RUN_TIMEOUT = 60.0


@dataclass(frozen=True, slots=True, kw_only=True)
class Coordinates:
    """A Maven artifact's coordinates, read from a pom."""

    group: str
    artifact: str
    version: str

    @classmethod
    def of(cls, pom: Path) -> Coordinates:
        root = ET.parse(pom).getroot()

        def text(tag: str) -> str:
            element = root.find(f"{POM}{tag}")
            assert element is not None and element.text is not None, (pom, tag)
            return element.text.strip()

        return cls(group=text("groupId"), artifact=text("artifactId"), version=text("version"))

    def directory(self) -> Path:
        """Where the local repository keeps this artifact."""
        return REPOSITORY.joinpath(*self.group.split("."), self.artifact, self.version)

    def jar(self) -> Path:
        return self.directory() / f"{self.artifact}-{self.version}.jar"


def _require_tools() -> None:
    missing = [tool for tool in ("mvn", "java") if shutil.which(tool) is None]
    if not missing:
        return
    reason = f"{' and '.join(missing)} not installed: the Java install tests need Maven and a JDK"
    if os.environ.get("OPENAIR_REQUIRE_BINDINGS") == "1":
        pytest.fail(reason, pytrace=False)
    pytest.skip(reason)


def _maven(project: Path, *args: str) -> None:
    """Run Maven offline and quiet in `project`; fail with its output when it fails."""
    done = subprocess.run(
        ["mvn", "-o", "-q", *args], cwd=project, capture_output=True, text=True,
        timeout=MAVEN_TIMEOUT,
    )  # fmt: skip
    assert done.returncode == 0, f"mvn {' '.join(args)} in {project}:\n{done.stdout}{done.stderr}"


# -- (a) mvn install --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Coordinates:
    """bindings/java installed into the local repository; its coordinates."""
    _require_tools()
    copy = tmp_path_factory.mktemp("java-install") / "java"
    copy.mkdir()
    shutil.copy2(JAVA_DIR / "pom.xml", copy / "pom.xml")
    shutil.copytree(JAVA_DIR / "src", copy / "src")
    _maven(copy, "install", "-DskipTests")
    assert (copy / "target" / "openair.jar").is_file()  # where the kit's tests expect the jar
    assert (copy / "target" / "openair-shim.jar").is_file()
    return Coordinates.of(JAVA_DIR / "pom.xml")


def test_install_puts_org_openair_openair_into_the_local_repository(
    installed: Coordinates,
) -> None:
    assert (installed.group, installed.artifact) == ("org.openair", "openair")
    pom = installed.directory() / f"{installed.artifact}-{installed.version}.pom"
    assert Coordinates.of(pom) == installed
    with zipfile.ZipFile(installed.jar()) as jar:
        names = set(jar.namelist())
    assert {"module-info.class", "org/openair/OpenAir.class", "org/openair/Options.class"} <= names
    assert not any(n.startswith("org/openair/shim/BrokenShimMain") for n in names)


# -- (b) a project that depends on it ---------------------------------------------------------


@pytest.fixture(scope="module")
def consumer(installed: Coordinates, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The consumer example, copied and built offline against the installed artifact."""
    copy = tmp_path_factory.mktemp("java-consumer") / "consumer"
    shutil.copytree(CONSUMER, copy, ignore=shutil.ignore_patterns("target"))
    _maven(copy, "package", f"-Dopenair.version={installed.version}")
    return copy


@pytest.fixture
def server() -> Iterator[ReferenceServer]:
    srv = ReferenceServer()
    try:
        yield srv
    finally:
        srv.stop()


def test_the_consumer_posts_through_the_installed_library(
    installed: Coordinates, consumer: Path, server: ReferenceServer
) -> None:
    content = "posted by the consumer ✓"
    classpath = os.pathsep.join([str(consumer / "target" / "classes"), str(installed.jar())])
    done = subprocess.run(
        ["java", "-cp", classpath, "org.openair.example.Consumer", "127.0.0.1",
         str(server.port), content],
        capture_output=True, text=True, timeout=RUN_TIMEOUT,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == f"openair {installed.version}"
    posted = re.fullmatch(r"posted Example\.Consumer\.Hello to WB1 (\S+)", lines[1])
    assert posted is not None and len(lines) == 2, done.stdout
    with BlockingModule("ConsumerCheck", port=server.port, keepalive=None) as checker:
        stored = checker.retrieve(RetrieveSpec(whiteboard="WB1", pattern="Example.*", latest=5))
    assert [(m.id, m.sender, m.content) for m in stored] == [(posted.group(1), "Consumer", content)]


def test_the_consumer_refuses_a_bad_port(installed: Coordinates, consumer: Path) -> None:
    classpath = os.pathsep.join([str(consumer / "target" / "classes"), str(installed.jar())])
    done = subprocess.run(
        ["java", "-cp", classpath, "org.openair.example.Consumer", "127.0.0.1", "abc"],
        capture_output=True, text=True, timeout=RUN_TIMEOUT,
    )  # fmt: skip
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr.splitlines() == ["Consumer: PORT is not a number: abc"]
