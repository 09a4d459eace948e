// A box turned off the grid: eight corners, twelve edges.
rotate([10, 20, 30]) cube([6, 5, 4], center = true);
