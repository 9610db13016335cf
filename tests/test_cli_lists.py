"""Issue 15 item 7, consistent list flags: every option taking several values
uses one argparse action (one or more values, space- or comma-separated, typed
per item, repeatable), and a bare list flag is a usage error naming it."""

import argparse

import pytest
from hypothesis import given, settings, strategies as st

from bandopt.cli import build_parser
from bandopt.cli._options import ListAction


def _subparsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices


def _parse(argv):
    return build_parser().parse_args(argv)


SIM = ["simulate", "--bands", "viirs-dnb", "--out", "o.csv"]


def test_every_list_option_uses_the_one_action():
    """An option taking a variable number of values is a ListAction (fixed
    arity tuples such as `--atmosphere ATM AER VIS` are not lists)."""
    seen = []
    for name, p in _subparsers().items():
        for a in p._actions:
            if not a.option_strings or isinstance(a.nargs, int):
                continue
            if a.nargs in ("*", "+") or isinstance(a, ListAction):
                assert isinstance(a, ListAction), (name, a.option_strings, a.nargs)
                assert a.nargs == "+", (name, a.option_strings)
                assert "one or more, space-" in a.help, (name, a.option_strings)
                assert "default" in a.help or "required" in a.help
                seen.append((name, a.option_strings[0]))
    expected = {
        ("simulate", "--lamps"),
        ("simulate", "--surfaces"),
        ("simulate", "--atmospheres"),
        ("simulate", "--moon"),
        ("simulate", "--classes"),
        ("radiometry", "--lamps"),
        ("classify", "--bands"),
        ("evaluate", "--lamps"),
        ("render", "--gsd"),
    }
    assert expected <= set(seen)


def test_comma_and_space_separated_are_the_same():
    a = _parse([*SIM, "--lamps", "a,b"])
    b = _parse([*SIM, "--lamps", "a", "b"])
    assert a.lamps == b.lamps == ["a", "b"]
    assert _parse([*SIM, "--lamps", "a,b", "c"]).lamps == ["a", "b", "c"]
    assert _parse([*SIM, "--lamps", " a , b"]).lamps == ["a", "b"]


def test_repeated_flag_accumulates_and_replaces_the_default():
    assert _parse([*SIM, "--lamps", "a", "--lamps", "b,c"]).lamps == ["a", "b", "c"]
    r = ["render", "--layout", "single", "--out", "o"]
    assert _parse(r).gsd == [10.0]
    assert _parse([*r, "--gsd", "5"]).gsd == [5.0]  # not [10.0, 5.0]
    assert _parse([*r, "--gsd", "5", "--gsd", "20"]).gsd == [5.0, 20.0]
    assert _parse(SIM).moon == ["none", "full"]
    assert _parse([*SIM, "--moon", "full"]).moon == ["full"]


def test_the_default_is_not_mutated_by_parsing():
    parser = build_parser()
    r = ["render", "--layout", "single", "--out", "o"]
    parser.parse_args([*r, "--gsd", "5"])
    assert parser.parse_args(r).gsd == [10.0]


@pytest.mark.parametrize("flag", ["--lamps", "--surfaces", "--moon", "--classes"])
def test_bare_list_flag_is_a_usage_error(flag, capsys):
    with pytest.raises(SystemExit) as e:
        _parse([*SIM, flag])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}" in err and "expected at least one argument" in err


def test_bare_list_flag_before_another_option(capsys):
    with pytest.raises(SystemExit) as e:
        _parse(["simulate", "--bands", "viirs-dnb", "--lamps", "--out", "o.csv"])
    assert e.value.code == 2 and "argument --lamps" in capsys.readouterr().err


def test_render_gsd_typed_per_item(capsys):
    r = ["render", "--layout", "single", "--out", "o"]
    assert _parse([*r, "--gsd", "10,20"]).gsd == [10.0, 20.0]
    assert _parse([*r, "--gsd", "2", "5,10"]).gsd == [2.0, 5.0, 10.0]
    with pytest.raises(SystemExit) as e:
        _parse([*r, "--gsd", "x"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "argument --gsd: invalid float value: 'x'" in err
    with pytest.raises(SystemExit):
        _parse([*r, "--gsd", "10,abc"])
    assert "argument --gsd: invalid float value: 'abc'" in capsys.readouterr().err


def test_empty_item_is_refused(capsys):
    with pytest.raises(SystemExit) as e:
        _parse([*SIM, "--lamps", "a,,b"])
    assert e.value.code == 2
    assert "argument --lamps: empty value in 'a,,b'" in capsys.readouterr().err


def test_file_options_keep_commas(tmp_path):
    """evaluate --lamps takes files: never split; classify --bands takes names
    or files: split, except a value that exists as a path."""
    ev = ["evaluate", "--bands", "viirs-dnb", "--lamps", "my,lamp.csv", "b.csv"]
    assert _parse(ev).lamps == ["my,lamp.csv", "b.csv"]
    assert "not split at commas" in next(
        a.help for a in _subparsers()["evaluate"]._actions if a.dest == "lamps"
    )
    f = tmp_path / "my,set.json"
    f.write_text("{}")
    c = _parse(["classify", "--bands", str(f), "viirs-dnb,sdgsat-1"])
    assert c.bands == [str(f), "viirs-dnb", "sdgsat-1"]


def test_list_option_help_states_convention_once(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["render", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "one or more, space- or comma-separated; repeatable; default: 10.0)" in out
    help_text = next(
        a.help for a in _subparsers()["render"]._actions if a.dest == "gsd"
    )
    assert help_text.count("default") == 1


def test_list_action_refuses_other_arities():
    p = argparse.ArgumentParser()
    with pytest.raises(ValueError, match="nargs must be"):
        p.add_argument("--x", action=ListAction, nargs=2)
    with pytest.raises(ValueError, match="item_type"):
        p.add_argument("--y", action=ListAction, type=float)


_token = st.text(
    alphabet=st.sampled_from("abcdefghijklmnopqrstuvwxyz_0123456789-"),
    min_size=1,
    max_size=8,
).filter(lambda t: not t.startswith("-"))


@settings(deadline=None, max_examples=60)
@given(
    items=st.lists(_token, min_size=1, max_size=6),
    cuts=st.lists(st.booleans(), min_size=6, max_size=6),
)
def test_any_grouping_parses_to_the_same_list(items, cuts):
    """Any mix of commas and spaces between the values gives the same list."""
    groups, cur = [], [items[0]]
    for item, cut in zip(items[1:], cuts, strict=False):
        if cut:
            groups.append(",".join(cur))
            cur = [item]
        else:
            cur.append(item)
    groups.append(",".join(cur))
    assert _parse([*SIM, "--classes", *groups]).classes == items
