"""Pick-and-place: the upper body follows a reference trajectory and moves an object while a frozen lower-body
policy keeps the robot standing."""
