"""./afm paper: the paper's experiments run on the bench (analysis.paper.cli)."""
