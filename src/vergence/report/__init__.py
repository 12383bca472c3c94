"""Reports and figures: matplotlib plots and the HTML gallery of ``vergence demo`` (interfaces layer)."""
