"""Reports and figures for people: Markdown and HTML documents, PNG/SVG/PDF figures."""
