"""joint_state_publisher and joint_state_publisher_gui (a web page of sliders) on Zenoh."""
