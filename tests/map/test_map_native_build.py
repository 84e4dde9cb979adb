"""The native map kernels are real C files shipped with the package, build warning-free into
a fresh cache, agree with the pure-torch path, and fall back to it (with a warning naming
the slowdown and the fix) when they cannot be built."""
from __future__ import annotations

import fnmatch
import importlib.resources
import logging
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import torch

from ramensim.agents.map import _native
from ramensim.agents.map.config import MapConfig
from ramensim.agents.map.decoders import Decoders, init_decoders
from ramensim.agents.map.hashgrid import GridSpec, encode_torch
from ramensim.agents.map.oneblob import oneblob_torch

REPO = Path(__file__).resolve().parents[2]
SOURCES = ("hashgrid.c", "oneblob.c", "adam.c", "visits.c", "render.c", "smooth.c", "mapmlp.c")
CC = _native._compiler()[0]
needs_cc = pytest.mark.skipif(shutil.which(CC) is None,
                              reason=f"no C compiler ({CC!r} not on PATH): the native kernels "
                                     f"cannot be built")


@pytest.mark.parametrize("name", SOURCES)
def test_sources_are_real_files_next_to_the_module(name):
    res = importlib.resources.files("ramensim.agents.map").joinpath("csrc", name)
    assert res.is_file()
    path = Path(str(res))
    assert path.resolve() == (Path(_native.__file__).resolve().parent / "csrc" / name)
    assert path.resolve() in {*_native.KERNEL_SOURCES, _native.MLP_SOURCE}
    text = path.read_text(encoding="utf-8")
    assert "#pragma omp parallel for" in text or "#pragma omp" in text
    # the C lives in the file, not in a Python string any more
    assert "#pragma omp" not in Path(_native.__file__).read_text(encoding="utf-8")


@pytest.mark.parametrize("name", (*SOURCES, "lanes.h", "hashgrid.h"))
def test_sources_are_package_data(name):
    """pyproject.toml ships csrc/*.c with ramensim.agents (a non-editable install has them)."""
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    agents_dir = REPO / cfg["package-dir"]["ramensim.agents"]
    rel = (_native.CSRC / name).relative_to(agents_dir.resolve()).as_posix()
    patterns = cfg["package-data"]["ramensim.agents"]
    assert any(fnmatch.fnmatch(rel, p) for p in patterns), (rel, patterns)


@needs_cc
@pytest.mark.parametrize("name, defines", [*((n, []) for n in SOURCES if n != "mapmlp.c"),
                                           ("mapmlp.c", []),  # the file's own defaults
                                           ("mapmlp.c", ["-DNG=8", "-DNP=6", "-DGH=5", "-DGO=3",
                                                         "-DCH=7"])])
def test_sources_compile_without_warnings(tmp_path, name, defines):
    flags = [f for f in (_native._MLP_FLAGS if name == "mapmlp.c" else _native._FLAGS)
             if f not in ("-shared", "-fPIC", "-g")]
    cmd = [*_native._compiler(), *flags, "-Werror", *defines, "-c",
           str(_native.CSRC / name), "-o", str(tmp_path / "x.o")]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("RAMENSIM_NO_NATIVE", raising=False)
    return tmp_path / "cache" / "native"


@needs_cc
def test_build_into_fresh_cache_matches_torch(fresh_cache):
    lib = _native._build()
    built = sorted(fresh_cache.glob("mapkernels_*.so"))
    assert len(built) == 1 and lib._name == str(built[0])
    mtime = built[0].stat().st_mtime_ns
    assert _native._build()._name == str(built[0])  # second build: a cache hit
    assert built[0].stat().st_mtime_ns == mtime
    assert not [p for p in fresh_cache.iterdir() if p.is_dir()]  # no temp dirs left behind

    spec = GridSpec.build(n_levels=8, features=2, log2_T=12, base_resolution=8,
                          finest_resolution=90)
    g = torch.Generator().manual_seed(0)
    x = torch.rand(37, 3, generator=g)
    x[:2] = torch.tensor([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    table = torch.randn(spec.n_params, generator=g) * 1e-2
    out = torch.empty(37, spec.out_dim)
    lib.hash_fwd(x.data_ptr(), 37, table.data_ptr(), spec.n_levels, spec.features, spec.T,
                 spec.scales.data_ptr(), spec.res.data_ptr(), spec.dense.data_ptr(),
                 out.data_ptr(), 1)
    assert torch.allclose(out, encode_torch(x, table, spec), atol=1e-6, rtol=0)

    ob = torch.empty(37, 3 * 16)
    lib.oneblob(x.data_ptr(), 37, 16, ob.data_ptr(), 2)
    assert torch.allclose(ob, oneblob_torch(x, 16), atol=1e-6)


@needs_cc
def test_mlp_build_is_keyed_by_shape_and_matches_torch(fresh_cache):
    cfg = MapConfig(n_levels=4, features_per_level=2, oneblob_bins=4, geo_hidden=12,
                    geo_feat_dim=5, color_hidden=9)
    shape = (8, 12, 12, 6, 9)
    lib = _native._build_mlp(*shape)
    other = _native._build_mlp(8, 12, 12, 6, 10)
    assert lib._name != other._name  # the shape macros are part of the cache key
    assert len(list(fresh_cache.glob("mapmlp_*.so"))) == 2

    dec = Decoders(init_decoders(cfg, torch.Generator().manual_seed(3)), cfg, torch.device("cpu"),
                   trainable=True)  # torch path only
    g = torch.Generator().manual_seed(4)
    feats, pe = torch.randn(21, 8, generator=g), torch.rand(21, 12, generator=g)
    pe[pe < 0.6] = 0.0  # the kernel skips zero OneBlob features (OneBlob: most are 0)
    w = [dec.params[k].detach().contiguous() for k in ("geo.0", "geo.1", "color.0", "color.1")]
    pe_t = torch.cat([w[0][:, 8:], w[2][:, :12]], dim=0).t().contiguous()
    sdf, raw = torch.empty(21), torch.empty(21, 3)
    lib.mlp_fwd(feats.data_ptr(), pe.data_ptr(), 21, *(t.data_ptr() for t in w),
                pe_t.data_ptr(), sdf.data_ptr(), raw.data_ptr(), 2)
    with torch.no_grad():
        sdf_t, raw_t = dec.forward(feats, pe)
    assert torch.allclose(sdf, sdf_t, atol=1e-5) and torch.allclose(raw, raw_t, atol=1e-5)


def _reset_state(monkeypatch):
    monkeypatch.setattr(_native, "_tried", False)
    monkeypatch.setattr(_native, "_lib", None)
    monkeypatch.setattr(_native, "_mlp_libs", {})


def test_missing_compiler_falls_back_with_a_useful_warning(fresh_cache, monkeypatch, caplog):
    _reset_state(monkeypatch)
    monkeypatch.setenv("CC", "ramensim-no-such-compiler")
    with caplog.at_level(logging.WARNING, logger=_native.__name__):
        assert _native.get_lib() is None
        assert _native.get_mlp_lib(8, 12, 12, 6, 9) is None
    msg = caplog.text
    assert "ramensim-no-such-compiler" in msg and "not found" in msg
    assert "pure-torch path" in msg and "slower" in msg  # the slowdown
    assert "install gcc" in msg and "CC" in msg and str(fresh_cache) in msg  # the fix
    assert not list(fresh_cache.glob("*.so"))


def test_failed_build_falls_back(fresh_cache, monkeypatch, caplog):
    _reset_state(monkeypatch)
    # a "compiler" that always fails, with a message
    monkeypatch.setenv("CC", f"{shlex.quote(sys.executable)} -c 'raise SystemExit(\"boom\")'")
    with caplog.at_level(logging.WARNING, logger=_native.__name__):
        assert _native.get_lib() is None
    assert "failed on hashgrid.c, oneblob.c" in caplog.text and "boom" in caplog.text and "slower" in caplog.text


def test_no_native_env_forces_torch_path(fresh_cache, monkeypatch, caplog):
    _reset_state(monkeypatch)
    monkeypatch.setenv("RAMENSIM_NO_NATIVE", "1")
    with caplog.at_level(logging.WARNING, logger=_native.__name__):
        assert _native.get_lib() is None
    assert "RAMENSIM_NO_NATIVE" in caplog.text and "slower" in caplog.text
    assert not fresh_cache.exists()  # nothing was built


def _c_prototypes(folder: Path) -> dict[str, list[str]]:
    """Entry point -> argument names, from every C file of ``folder``."""
    import re

    out = {}
    for src in folder.glob("*.c"):
        for m in re.finditer(r"^(?:void|int64_t|int)\s+(\w+)\(([^)]*)\)\s*\{", src.read_text(), re.M):
            out[m.group(1)] = [re.split(r"[\s*]+", a.strip())[-1] for a in m.group(2).split(",")]
    return out


def test_signature_tables_match_the_c_prototypes():
    """Each kernel's ctypes table names its arguments; they are the C prototype's, in order
    (a C signature that changes without its table fails here, not as a crash at run time)."""
    from ramensim.agents.consensus import _native as consensus_native
    from ramensim.evaluation import _native as eval_native

    for tables, folder in ((_native.SIGNATURES | _native.MLP_SIGNATURES, _native.CSRC),
                           (consensus_native.SIGNATURES, consensus_native.SOURCE.parent),
                           (eval_native.SIGNATURES, eval_native.SOURCE.parent)):
        protos = _c_prototypes(folder)
        for fn, args in tables.items():
            assert [name for name, _ in args] == protos[fn], fn
        assert set(protos) == set(tables)  # every entry point has its table


def test_constants_are_written_once():
    """The hash primes live in csrc/hashgrid.h; Python reads them from there."""
    from ramensim.agents.map.hashgrid import PRIMES
    from ramensim.core.native import read_define

    header = _native.CSRC / "hashgrid.h"
    assert PRIMES == (1, read_define(header, "P1"), read_define(header, "P2")) == (1, 2654435761, 805459861)
    for src in _native.CSRC.glob("*.c"):
        assert "2654435761" not in src.read_text()


def test_cache_key_covers_every_included_file(fresh_cache, tmp_path):
    """Editing a header rebuilds the kernels that include it (the key hashes every file read)."""
    from ramensim.core.native import compile_shared

    src = tmp_path / "k.c"
    (tmp_path / "k.h").write_text("#define K 1\n")
    src.write_text('#include "k.h"\nint k(void) { return K; }\n')
    flags = ["-O1", "-shared", "-fPIC"]
    a = compile_shared(src, "k", flags)
    (tmp_path / "k.h").write_text("#define K 2\n")
    b = compile_shared(src, "k", flags)
    assert a._name != b._name and b.k() == 2
