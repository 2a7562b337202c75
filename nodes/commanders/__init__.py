"""The tutorials' command nodes: joint commander, Lab 2.3 wave controller and monitor, the controller
lab's trajectory sender, the Atlas joint animation player and an automatic joint-state publisher."""
