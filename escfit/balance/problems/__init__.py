"""Balance-wheel and pendulum fit problems: scene + recording + observation model -> likelihood."""
