"""What the report needs beyond the metrics: spectra, effective samples, periodic noise, physics."""
