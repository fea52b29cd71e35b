# SPDX-License-Identifier: MIT
# Type stubs of meshmark's compiled core, the extension meshmark._meshmark (python/src/*.cpp).
# tests/python/test_stubs.py checks them against the module: the same public names, and for
# every function and method the same parameters, in the same order and of the same kinds.
# Reports (dict[str, Any]) are the meshmark program's --json objects: docs/cli.md.
import os
import pathlib
from collections.abc import Sequence
from typing import Any, ClassVar, Literal, overload

import numpy
import numpy.typing

__version__: str

# A file name: a str or any os.PathLike (os.fspath); paths returned are pathlib.Path.
_Path = str | os.PathLike[str]
_Report = dict[str, Any]
_Positions = numpy.typing.NDArray[numpy.float64]
_Faces = numpy.typing.NDArray[numpy.int32]

class Error(Exception):
    """Base of every meshmark error; str(e) is the program's one-sentence message."""

class IoError(Error): ...
class InvalidMesh(Error): ...
class InvalidOption(Error): ...
class NumericalError(Error): ...

class Key:
    @staticmethod
    def load(path: _Path) -> Key: ...
    def save(self, path: _Path, *, force: bool = ..., lock_timeout: float = ...) -> None: ...
    @staticmethod
    def from_json(text: str) -> Key: ...
    def to_json(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def message(self) -> str | None: ...
    @property
    def bits(self) -> str: ...
    @property
    def payload(self) -> str: ...
    @property
    def rule(self) -> str: ...
    @property
    def strength(self) -> float: ...
    @property
    def strength_measure(self) -> str: ...
    @property
    def vertex_strength(self) -> float: ...
    @property
    def basis(self) -> str: ...
    @property
    def centers(self) -> str: ...
    @property
    def basis_size(self) -> int: ...
    @property
    def coefficients(self) -> int: ...
    @property
    def repetitions(self) -> int: ...
    @property
    def first_mode(self) -> int: ...
    @property
    def sigma_factor(self) -> float: ...
    @property
    def gram_rows(self) -> int: ...
    @property
    def original_vertices(self) -> int: ...
    @property
    def original_faces(self) -> int: ...
    def __eq__(self, other: object) -> bool: ...
    __hash__: ClassVar[None]  # type: ignore[assignment]

class DetectResult:
    @property
    def detected(self) -> bool: ...
    @property
    def headline(self) -> str: ...
    @property
    def owner_detected(self) -> bool: ...
    @property
    def recipients(self) -> list[dict[str, Any]]: ...
    @property
    def verdict(self) -> str: ...
    @property
    def score(self) -> float: ...
    @property
    def false_positive_probability(self) -> float: ...
    @property
    def score_false_positive_probability(self) -> float: ...
    @property
    def bits_false_positive_probability(self) -> float: ...
    @property
    def correlation(self) -> float: ...
    @property
    def matches(self) -> int: ...
    @property
    def bit_count(self) -> int: ...
    @property
    def coefficient_count(self) -> int: ...
    @property
    def bits_expected(self) -> str: ...
    @property
    def bits_found(self) -> str: ...
    @property
    def cropped_fraction(self) -> float: ...
    @property
    def outlier_fraction(self) -> float: ...
    @property
    def alignment(self) -> str: ...
    @property
    def registration_rms(self) -> float: ...
    @property
    def mark_strength(self) -> float: ...
    @property
    def voxel_resolution(self) -> float: ...
    @property
    def is_far_copy(self) -> bool: ...
    @property
    def transform(self) -> numpy.typing.NDArray[numpy.float64]: ...
    @property
    def suspect_vertices(self) -> int: ...
    @property
    def original_vertices(self) -> int: ...
    def to_dict(self) -> _Report: ...

class Catalog:
    def __init__(self, path: _Path, *, create: bool = ..., lock_timeout: float = ...) -> None: ...
    @property
    def path(self) -> pathlib.Path: ...
    def add(
        self,
        inputs: Sequence[_Path],
        output: _Path,
        *,
        seed: int | None = ...,
        strength: float | None = ...,
        message: str | None = ...,
        basis_size: int = ...,
        coefficients: int = ...,
        jobs: int = ...,
        force: bool = ...,
        lock_timeout: float = ...,
        threads: int = ...,
        client: Any | None = ...,  # a dask.distributed Client (meshmark.cluster)
    ) -> _Report: ...
    def list(self) -> list[dict[str, Any]]: ...
    def issue(
        self,
        asset: str,
        recipients: Sequence[str],
        output_pattern: str,
        *,
        recipients_file: _Path | None = ...,
        lock_timeout: float = ...,
        threads: int = ...,
        client: Any | None = ...,  # a dask.distributed Client (meshmark.cluster)
    ) -> _Report: ...
    def scan(
        self,
        suspects: Sequence[_Path],
        *,
        candidates: int = ...,
        more_candidates: int = ...,
        all_candidates: bool = ...,
        max_fpp: float = ...,
        trace: bool = ...,
        threads: int = ...,
        client: Any | None = ...,  # a dask.distributed Client (meshmark.cluster)
        report: _Path | None = ...,
    ) -> _Report: ...
    def reindex(self, *, all: bool = ..., threads: int = ...) -> _Report: ...
    def key(self, asset: str) -> Key: ...

# report=True adds the embed report (a third item).
@overload
def embed(
    V: numpy.typing.ArrayLike,
    F: numpy.typing.ArrayLike | None = ...,
    *,
    message: str | None = ...,
    bits: str | None = ...,
    seed: int | None = ...,
    strength: float | None = ...,
    rule: str = ...,
    strength_measure: str = ...,
    basis: str = ...,
    centers: str = ...,
    basis_size: int = ...,
    coefficients: int = ...,
    repetitions: int | str = ...,
    first_mode: int = ...,
    sigma_factor: float = ...,
    gram_rows: int = ...,
    threads: int = ...,
    report: Literal[False] = ...,
) -> tuple[Key, _Positions]: ...
@overload
def embed(
    V: numpy.typing.ArrayLike,
    F: numpy.typing.ArrayLike | None = ...,
    *,
    message: str | None = ...,
    bits: str | None = ...,
    seed: int | None = ...,
    strength: float | None = ...,
    rule: str = ...,
    strength_measure: str = ...,
    basis: str = ...,
    centers: str = ...,
    basis_size: int = ...,
    coefficients: int = ...,
    repetitions: int | str = ...,
    first_mode: int = ...,
    sigma_factor: float = ...,
    gram_rows: int = ...,
    threads: int = ...,
    report: Literal[True],
) -> tuple[Key, _Positions, _Report]: ...
def detect(
    V_suspect: numpy.typing.ArrayLike,
    F_suspect: numpy.typing.ArrayLike | None,
    V_original: numpy.typing.ArrayLike,
    F_original: numpy.typing.ArrayLike | None,
    key: Key,
    *,
    verdict: str = ...,
    max_fpp: float = ...,
    threshold: float = ...,
    epsilon: float = ...,
    register: bool = ...,
    pairs: _Path | numpy.typing.ArrayLike | None = ...,
    trace: bool = ...,
    threads: int = ...,
    verbose: bool = ...,
) -> DetectResult: ...
def detect_against_file(
    V_suspect: numpy.typing.ArrayLike,
    F_suspect: numpy.typing.ArrayLike | None,
    original: _Path,
    key_path: _Path,
    *,
    verdict: str = ...,
    max_fpp: float = ...,
    threshold: float = ...,
    epsilon: float = ...,
    register: bool = ...,
    pairs: _Path | numpy.typing.ArrayLike | None = ...,
    trace: bool = ...,
    threads: int = ...,
    verbose: bool = ...,
) -> DetectResult: ...
def attack_mesh(
    V: numpy.typing.ArrayLike,
    F: numpy.typing.ArrayLike | None,
    spec: str,
    *,
    seed: int = ...,
    threads: int = ...,
) -> tuple[_Positions, _Faces | None]: ...
def read_mesh(path: _Path) -> tuple[_Positions, _Faces | None]: ...
def write_mesh(
    path: _Path,
    V: numpy.typing.ArrayLike,
    F: numpy.typing.ArrayLike | None = ...,
    *,
    binary: bool = ...,
) -> None: ...
def embed_file(
    input: _Path,
    output: _Path,
    key_path: _Path,
    *,
    message: str | None = ...,
    bits: str | None = ...,
    seed: int | None = ...,
    strength: float | None = ...,
    rule: str = ...,
    strength_measure: str = ...,
    basis: str = ...,
    centers: str = ...,
    basis_size: int = ...,
    coefficients: int = ...,
    repetitions: int | str = ...,
    first_mode: int = ...,
    sigma_factor: float = ...,
    gram_rows: int = ...,
    threads: int = ...,
    force: bool = ...,
    memory_budget: int = ...,
    stream: bool = ...,
    lock_timeout: float = ...,
    unit: str | None = ...,
    max_displacement: str | float | None = ...,
    record: _Path | None = ...,
) -> _Report: ...
def embed_recipients(
    input: _Path,
    output_pattern: str,
    key_path: _Path,
    recipients: Sequence[str] = ...,
    *,
    recipients_file: _Path | None = ...,
    message: str | None = ...,
    bits: str | None = ...,
    seed: int | None = ...,
    strength: float | None = ...,
    strength_measure: str = ...,
    centers: str = ...,
    basis_size: int = ...,
    coefficients: int = ...,
    repetitions: int | str = ...,
    first_mode: int = ...,
    sigma_factor: float = ...,
    gram_rows: int = ...,
    recipient_modes: int = ...,
    recipient_share: float = ...,
    lock_timeout: float = ...,
    threads: int = ...,
) -> _Report: ...
def detect_file(
    suspect: _Path,
    original: _Path,
    key_path: _Path,
    *,
    verdict: str = ...,
    max_fpp: float = ...,
    threshold: float = ...,
    epsilon: float = ...,
    register: bool = ...,
    pairs: _Path | numpy.typing.ArrayLike | None = ...,
    trace: bool = ...,
    threads: int = ...,
    verbose: bool = ...,
    report: _Path | None = ...,
) -> _Report: ...
def attack(
    input: _Path,
    spec: str,
    output: _Path,
    *,
    seed: int = ...,
    force: bool = ...,
    threads: int = ...,
) -> _Report: ...
def compare(
    a: _Path,
    b: _Path,
    *,
    samples: int = ...,
    seed: int = ...,
    heatmap: _Path | None = ...,
    view: str | None = ...,
    size: str | None = ...,
    up: str | None = ...,
    unit: str | None = ...,
    threads: int = ...,
) -> _Report: ...

# Private: catalogue work's steps for meshmark.cluster (docs/cluster.md).
_Files = list[tuple[str, bytes]]
def _catalog_plan_add(
    catalog: Catalog,
    inputs: Sequence[_Path],
    output: _Path,
    *,
    seed: int | None = ...,
    strength: float | None = ...,
    message: str | None = ...,
    basis_size: int = ...,
    coefficients: int = ...,
    force: bool = ...,
) -> tuple[list[str | None], list[tuple[str, str]]]: ...
def _catalog_mark(task: str, threads: int = ...) -> tuple[str, _Files]: ...
def _catalog_record(catalog: Catalog, task: str, marked: str, files: _Files) -> str: ...
def _catalog_add_report(catalog: Catalog, outcomes: Sequence[str | None]) -> _Report: ...
def _catalog_plan_issue(
    catalog: Catalog,
    asset: str,
    recipients: Sequence[str],
    output_pattern: str,
    *,
    recipients_file: _Path | None = ...,
    lock_timeout: float = ...,
    per_task: int = ...,
) -> tuple[str, list[tuple[str, str]]]: ...
def _catalog_make_copies(task: str, threads: int = ...) -> tuple[str, _Files]: ...
def _catalog_deliver(catalog: Catalog, task: str, made: str, files: _Files) -> None: ...
def _catalog_issue_report(
    catalog: Catalog, asset: str, plan: str, made: Sequence[str], seconds: float
) -> _Report: ...
