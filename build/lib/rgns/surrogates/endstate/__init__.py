"""The end-state surrogate: a U-Net from a slope's material points and friction field, laid out on
their own lattice, to each point's final displacement (a grid-based surrogate beside the GNS)."""
