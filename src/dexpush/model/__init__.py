"""The pushed object and its physics: shapes and their contour tables, the C-GVMM (Algorithm 1)
and the two-contact corner solve."""
