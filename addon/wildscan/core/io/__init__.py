"""File formats (numpy only): each module turns scan data into the bytes of one format."""
