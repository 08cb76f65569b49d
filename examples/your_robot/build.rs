//! Generate the robot's barrier code from its spec into OUT_DIR whenever the spec changes.

fn main() {
    cbfgen_build::Generator::new().spec("spec/your_robot.py").build();
}
