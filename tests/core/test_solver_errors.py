"""Bad solver options give one clear error naming where they came from."""

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
