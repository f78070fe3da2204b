"""Device conformance suite and emulator tests (a package, so module names stay unique)."""
