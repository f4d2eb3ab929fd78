"""What every part of dexpush uses: input checks, atomic files, SE(2) helpers, float32 fast math,
the loop's protocols (:mod:`dexpush.common.interfaces`) and the XLA process options."""
