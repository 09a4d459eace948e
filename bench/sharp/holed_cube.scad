// A cube with a turned square hole: flat faces, sharp convex and concave edges off the grid.
difference() { cube(10, center = true); rotate([30, 20, 10]) cube([4, 4, 20], center = true); }
