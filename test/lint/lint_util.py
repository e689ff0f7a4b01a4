"""Helpers shared by the tests of the code checkers in scripts/ (check_*_test.py)."""

import pathlib
import subprocess
import sys
import tempfile


def RunOnTree(checker, tree, *extra):
  """(exit status, stdout) of `checker` on a made-up tree (dict: relative path -> text)."""
  with tempfile.TemporaryDirectory() as tmp:
    root = pathlib.Path(tmp)
    for path, text in tree.items():
      (root / path).parent.mkdir(parents=True, exist_ok=True)
      (root / path).write_text(text)
    done = subprocess.run([sys.executable, str(checker), *extra, str(root)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return done.returncode, done.stdout


class Failures(list):
  """The failed cases of a checker test, each as 'name: detail'."""

  def Expect(self, name, condition, detail=""):
    if not condition:
      self.append(f"{name}: {detail}")
