"""The viewer: RViz and rqt_plot for the stack, on Rerun (``python -m nodes.viz``)."""
