"""compare: ranking, verdict and the words of its reasons."""
