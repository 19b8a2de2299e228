"""An assessment from videos to scores: chunked, resumable, using both cores."""
