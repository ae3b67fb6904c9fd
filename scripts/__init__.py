"""The project's scripts, grouped by purpose; ``scripts.common`` holds what they share
with each other and with the tests (the repository root on ``sys.path``, as pytest has it)."""
