"""A folder per fuzz module, written over and over by thousands of cases: in memory
(/dev/shm) where there is one, since creating a file on a busy disk takes milliseconds
and the cases themselves take a fraction of one."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

_MEMORY = Path("/dev/shm")


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    if not _MEMORY.is_dir():
        yield tmp_path_factory.mktemp("fuzz")
        return
    path = Path(tempfile.mkdtemp(prefix="giraff-fuzz-", dir=_MEMORY))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
