"""The analyses of the source documents: Brause's linear-approximation error and storage (§5-6),
his optimal resolution (§6.2, appendix B), Němeček's kinematic accuracy, the RIACS data set."""
