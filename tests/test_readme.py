"""The README's examples run (documentation that cannot rot)."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

README = (Path(__file__).parents[1] / "README.md").read_text()
PYTHON_BLOCKS = re.findall(r"```python\n(.*?)```", README, re.S)


@pytest.mark.parametrize("code", PYTHON_BLOCKS, ids=[f"block{i}" for i in range(len(PYTHON_BLOCKS))])
def test_python_examples_run(code, tmp_path):
    script = tmp_path / "example.py"
    script.write_text(code)
    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr


def test_console_example_is_what_the_cli_prints():
    command, expected = re.search(r"```console\n\$ (.*?)\n(.*?)\n```", README, re.S).groups()
    args = command.split()[1:]
    result = subprocess.run([sys.executable, "-m", "fsivsp.cli", *args], capture_output=True, text=True)
    assert result.returncode == 2
    assert result.stderr.strip() == expected.strip()
