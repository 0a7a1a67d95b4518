"""The mergeable sums behind the streaming accumulator."""
