"""The paper's figures (ultra-slow shocks in a lattice of magnets), one module per figure:
fig1-4, s3-s9, movies."""
