"""The paper's experiments, one function per table or figure."""
