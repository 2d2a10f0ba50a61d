"""Bad solver options give one clear error naming where they came from."""

import os

import pytest

import optplan as op


def test_unknown_override_is_attributed_to_the_override():
    with pytest.raises(ValueError, match=r"^override: unknown option 'n_particle'.*'n_particles'"):
        op.get_solver("pso-paper", n_particle=10)


def test_bad_value_in_preset_file_names_the_file_and_option(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text('backend = "pso"\n[options]\nc1 = -1.0\n', encoding="utf-8")
    with pytest.raises(ValueError, match=r"bad\.toml: option 'c1' of backend 'pso' must be "
                                         r"a number in \[0, 10\], got -1.0"):
        op.get_solver(str(f))


def test_bad_override_value_names_preset_and_overrides():
    with pytest.raises(ValueError, match=r"pso-paper\.toml with overrides \['k_max'\]: .*k_max"):
        op.solve("open-field", "pso-paper", k_max=-3)


def test_unknown_key_in_preset_file(tmp_path):
    f = tmp_path / "typo.toml"
    f.write_text('backend = "pso"\nsumary = "x"\n', encoding="utf-8")
    with pytest.raises(ValueError, match=r"typo\.toml: sumary: unknown key; did you mean"):
        op.get_solver(str(f))


def test_an_edited_preset_file_is_read_again(tmp_path):
    """A preset's parse is kept between solves only while the file's text is unchanged: an
    edit is seen at once (the same size, the same modification time), a bad edit is reported,
    and changing what a read returned changes nothing the next read returns."""
    from optplan.catalog import read_preset

    f = tmp_path / "mine.toml"
    f.write_text('backend = "pso"\n[options]\nc1 = 1.5\n', encoding="utf-8")
    assert op.get_solver(str(f)).c1 == 1.5
    st = f.stat()
    f.write_text('backend = "pso"\n[options]\nc1 = 2.5\n', encoding="utf-8")
    os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns))  # the same time: only the text differs
    assert op.get_solver(str(f)).c1 == 2.5
    read_preset(f)["options"]["c1"] = 9.0
    assert read_preset(f)["options"]["c1"] == 2.5
    f.write_text('backend = "pso"\n[options]\nc1 = -1.0\n', encoding="utf-8")
    with pytest.raises(ValueError, match=r"mine\.toml: option 'c1'"):
        op.get_solver(str(f))


def test_a_preset_added_to_the_catalogue_is_listed(tmp_path, monkeypatch):
    """The shipped presets' listing is kept while the directory's file names are unchanged;
    a file added there is listed at once (whatever the directory's modification time)."""
    import optplan.catalog as cat

    d = tmp_path / "solvers"
    d.mkdir()
    (d / "a.toml").write_text('backend = "pso"\n', encoding="utf-8")
    monkeypatch.setattr(cat, "catalog_dir", lambda kind: tmp_path / kind)
    assert list(cat.preset_files()) == ["a"]
    st = d.stat()
    (d / "b.toml").write_text('backend = "pso"\n', encoding="utf-8")
    os.utime(d, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert list(cat.preset_files()) == ["a", "b"]
