"""NumPy twins of GPU kernels, used only by the tests."""
