from .cli import main

if __name__ == "__main__":  # a spawned process (spinemesh.pack.png) imports this module again
    main()
