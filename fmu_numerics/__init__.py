"""The numerics every core stands on, with the same bits on every machine and in either build: the
elementary functions (elementary; elementary_big, the exact reduction of huge angles; elementary_interpreted,
the interpreted build's whole-array twin) and fixed-order linear algebra (fixed_linalg). Imports numpy,
math and itself only: every other package may import it, it imports none of them."""
