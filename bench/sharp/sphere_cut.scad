// A $fn = 96 sphere cut by a turned cube: curved faces meeting flat ones.
intersection() { sphere(5, $fn = 96); rotate([15, 25, 0]) cube(7.5, center = true); }
