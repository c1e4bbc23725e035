"""my_summit_navigation: the course's step 4 (/get_coordinates) -- the pure logic."""
