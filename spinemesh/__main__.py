if __name__ == "__main__":  # a spawned process (spinemesh.pack.png) imports this module again
    try:
        from .cli import main
    except KeyboardInterrupt:  # Ctrl-C while the command line is imported: as a Ctrl-C a moment later
        raise SystemExit(130) from None
    main()
