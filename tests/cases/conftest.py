"""Fixtures of the tests of the ``cases`` layer (CLI, faults, figures, viewer)."""

import pytest

from cases import cli


@pytest.fixture
def colony(capsys):
    """``colony(*ARGS) -> (exit status, stderr)``: the ``colony`` command run in this process."""

    def run(*args):
        status = cli.main(list(args))
        return status, capsys.readouterr().err

    return run
