"""Examples to copy: how to write a model of the evolution engine and a model kind of the
toolkit (``examples/README.md``). Not installed with the toolkit; importable from the
repository's root, where the tests run them."""
