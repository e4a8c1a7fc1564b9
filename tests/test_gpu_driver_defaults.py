"""The driver settings mane asks for before its first context (``gpu.context.driver_defaults``)."""
from __future__ import annotations

import os
import subprocess
import sys

from mane.gpu import context


def test_defaults_fill_only_what_the_user_left_unset(monkeypatch):
    monkeypatch.delenv("__GL_THREADED_OPTIMIZATIONS", raising=False)
    context.driver_defaults()
    assert os.environ["__GL_THREADED_OPTIMIZATIONS"] == "1"
    monkeypatch.setenv("__GL_THREADED_OPTIMIZATIONS", "0")   # the user's own choice stays
    context.driver_defaults()
    assert os.environ["__GL_THREADED_OPTIMIZATIONS"] == "0"


def test_a_fresh_process_has_them_before_its_context_loads_the_driver():
    env = {k: v for k, v in os.environ.items() if k != "__GL_THREADED_OPTIMIZATIONS"}
    code = ("import os, mane.gpu as g\n"
            "before = os.environ.get('__GL_THREADED_OPTIMIZATIONS')\n"
            "ctx = g.get_context()\n"
            "print(before, os.environ.get('__GL_THREADED_OPTIMIZATIONS'), ctx.version_code >= 430)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["None", "1", "True"], out.stderr
