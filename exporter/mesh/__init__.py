"""The mesh layer: geometry kernels that every stage uses and that import no stage."""
