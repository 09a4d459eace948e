// A plate with holes and a chamfered boss, as a bracket is made ($fn = 96 cylinders).
$fn = 96;
difference() {
  union() { cube([30, 20, 4]); translate([15, 10, 0]) cylinder(r1 = 7, r2 = 5, h = 10); }
  translate([15, 10, -1]) cylinder(r = 3, h = 12);
  for (x = [5, 25]) translate([x, 5, -1]) cylinder(r = 2, h = 6);
}
