"""The robustness leaderboard (``python -m chaincart_env leaderboard``): every controller,
model-based and learned, scored by its success fraction along robustness axes, with
statistics over seeds as rliable recommends."""
